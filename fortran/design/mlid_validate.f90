!> How well an identified model predicts a record it was not fitted to
!> (the initial state and output biases the identification fitted are
!> refitted there, every other parameter held): per output Theil's inequality coefficient
!>   U = rms(y - yhat) / (rms(y) + rms(yhat))
!> (0 a perfect prediction, 1 none at all), the rms prediction error and
!> its ratio to the identification's residual sigma sqrt(R_ii) (near 1: the
!> held-out record is predicted as well as the fitted one was fitted).
module mlid_validate
  use mlid_kinds, only: wp
  implicit none
  private
  public :: prediction_stats

contains

  !> y, yhat (ny, nt): measured and predicted outputs; rhat (ny, ny): the
  !> identification's noise covariance.  A zero denominator gives 0.
  subroutine prediction_stats(y, yhat, rhat, theil, rms, ratio)
    real(wp), intent(in) :: y(:, :), yhat(:, :), rhat(:, :)
    real(wp), intent(out) :: theil(:), rms(:), ratio(:)
    real(wp) :: ry, rp
    integer :: i, nt

    nt = max(size(y, 2), 1)
    do i = 1, size(y, 1)
      rms(i) = sqrt(sum((y(i, :) - yhat(i, :))**2)/nt)
      ry = sqrt(sum(y(i, :)**2)/nt)
      rp = sqrt(sum(yhat(i, :)**2)/nt)
      theil(i) = 0.0_wp
      if (ry + rp > 0.0_wp) theil(i) = rms(i)/(ry + rp)
      ratio(i) = 0.0_wp
      if (rhat(i, i) > 0.0_wp) ratio(i) = rms(i)/sqrt(rhat(i, i))
    end do
  end subroutine prediction_stats

end module mlid_validate
