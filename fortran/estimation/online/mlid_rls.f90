!> Recursive least squares for a linear regression y(k) = x(k)' theta + e(k),
!> sample by sample (Jategaonkar 2015, eqs 7.16-7.18; Klein and Morelli,
!> sec. 7.3), with a forgetting factor lambda <= 1:
!>
!>   K = P x / (lambda + x' P x)
!>   theta <- theta + K (y - x' theta)
!>   P <- (P - K x' P) / lambda
!>
!> With lambda < 1 and no excitation (x' P x small) P grows as lambda^-k
!> (wind-up); a bound p_max > 0 on trace(P)/n stops it: where the division
!> by lambda would pass the bound, P is not divided (forgetting pauses
!> until new excitation shrinks P again).
!>
!> sigma: sqrt(s2 diag P), s2 the residual variance of the a-posteriori
!> residuals so far, weighted as the data are (lambda^(k-j)), divided by the
!> effective number of samples less the parameters.  Under forgetting this
!> is the sigma of the weighted problem, not of the whole record; with
!> lambda = 1 and P0 large it tends to the batch least-squares sigma.
module mlid_rls
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_MEMORY
  use mlid_text, only: itoa, es_text
  implicit none
  private
  public :: rls_settings_t, rls_run

  !> The estimator's settings: forgetting factor, start, P0 (a multiple of
  !> I) and the bound on trace(P)/n (0: none).
  type :: rls_settings_t
    real(wp) :: lambda = 1.0_wp
    real(wp) :: p0 = 1.0e6_wp
    real(wp) :: p_max = 0.0_wp
  end type rls_settings_t

contains

  !> theta(:, k), sigma(:, k): the estimate and its sigma after sample k of
  !> the regressors x(np, n) and measurements y(n), from theta0.
  subroutine rls_run(x, y, theta0, s, theta, sigma, status, msg)
    real(wp), intent(in) :: x(:, :), y(:), theta0(:)
    type(rls_settings_t), intent(in) :: s
    real(wp), intent(out) :: theta(size(x, 1), size(x, 2)), sigma(size(x, 1), size(x, 2))
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: p(:, :)
    real(wp) :: th(size(x, 1)), px(size(x, 1)), k(size(x, 1)), e, ssq, nw
    integer :: np, j, i, ierr

    theta = 0.0_wp
    sigma = 0.0_wp
    call check(x, y, theta0, s, status, msg)
    if (status /= MLID_OK) return
    np = size(x, 1)
    allocate (p(np, np), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'recursive least squares: out of memory'
      return
    end if
    p = 0.0_wp
    do i = 1, np
      p(i, i) = s%p0
    end do
    th = theta0
    ssq = 0.0_wp                         ! weighted sum of squared residuals
    nw = 0.0_wp                          ! weighted number of samples
    do j = 1, size(y)
      px = matmul(p, x(:, j))
      k = px/(s%lambda + dot_product(x(:, j), px))
      th = th + k*(y(j) - dot_product(x(:, j), th))
      call update_p(p, k, px, s)
      e = y(j) - dot_product(x(:, j), th)
      ssq = s%lambda*ssq + e**2
      nw = s%lambda*nw + 1.0_wp
      theta(:, j) = th
      if (nw > np) sigma(:, j) = sqrt(max(ssq/(nw - np), 0.0_wp)*[(p(i, i), i=1, np)])
    end do
    status = MLID_OK
    msg = ''
  end subroutine rls_run

  !> P <- (P - K (P x)') / lambda, symmetric; the division skipped where it
  !> would take trace(P)/n past p_max.
  subroutine update_p(p, k, px, s)
    real(wp), intent(inout) :: p(:, :)
    real(wp), intent(in) :: k(:), px(:)
    type(rls_settings_t), intent(in) :: s
    integer :: i, np
    np = size(k)
    do i = 1, np
      p(:, i) = p(:, i) - k*px(i)
    end do
    p = 0.5_wp*(p + transpose(p))
    if (s%lambda >= 1.0_wp) return
    if (s%p_max > 0.0_wp) then
      if (sum([(p(i, i), i=1, np)])/s%lambda > s%p_max*np) return
    end if
    p = p/s%lambda
  end subroutine update_p

  subroutine check(x, y, theta0, s, status, msg)
    real(wp), intent(in) :: x(:, :), y(:), theta0(:)
    type(rls_settings_t), intent(in) :: s
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    status = MLID_ERR_INPUT
    if (size(x, 1) < 1 .or. size(y) < 1) then
      msg = 'recursive least squares needs at least one regressor and one sample'
    else if (size(x, 2) /= size(y) .or. size(theta0) /= size(x, 1)) then
      msg = 'recursive least squares: '//itoa(size(x, 2))//' regressor samples, '// &
            itoa(size(y))//' measurements and '//itoa(size(theta0))//' start values for '// &
            itoa(size(x, 1))//' parameters'
    else if (.not. (s%lambda > 0.0_wp .and. s%lambda <= 1.0_wp)) then
      msg = 'the forgetting factor must be in (0, 1], not '//trim(adjustl(es_text(s%lambda, 10, 3)))
    else if (.not. (s%p0 > 0.0_wp .and. ieee_is_finite(s%p0))) then
      msg = 'P0 (the start covariance, a multiple of I) must be > 0 and finite'
    else if (.not. (s%p_max >= 0.0_wp .and. ieee_is_finite(s%p_max))) then
      msg = 'the covariance bound p_max must be >= 0 (0: none) and finite'
    else if (.not. (all(ieee_is_finite(x)) .and. all(ieee_is_finite(y)) .and. &
                    all(ieee_is_finite(theta0)))) then
      msg = 'recursive least squares: regressors, measurements and start values must be finite'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine check

end module mlid_rls
