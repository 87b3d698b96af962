!> What an online estimator's history says, the same for every estimator
!> and both front ends: when each estimate converged.
module mlid_online_history
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp
  implicit none
  private
  public :: convergence_times

contains

  !> For each parameter (a row of est, a column per point of the history
  !> at the times t), the first time after which its estimate stays within
  !> width times its final sigma of its final value; NaN when the final
  !> sigma is not > 0.  A point without an estimate (NaN) is outside.
  pure function convergence_times(t, est, sig, width) result(tc)
    real(wp), intent(in) :: t(:), est(:, :), sig(:, :), width
    real(wp) :: tc(size(est, 1))
    integer :: i, k, n
    n = size(t)
    do i = 1, size(est, 1)
      tc(i) = ieee_value(1.0_wp, ieee_quiet_nan)
      if (n == 0) cycle
      if (.not. sig(i, n) > 0.0_wp) cycle
      tc(i) = t(1)
      do k = n, 1, -1
        if (.not. abs(est(i, k) - est(i, n)) <= width*sig(i, n)) then
          if (k < n) tc(i) = t(k + 1)
          if (k == n) tc(i) = t(n)
          exit
        end if
      end do
    end do
  end function convergence_times

end module mlid_online_history
