!> The flat interface's online (recursive) estimation.  Recursive least
!> squares takes its few arrays directly (a regression, not a model).
!> Conventions: mlid_api_deck's comment.
module mlid_api_online
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use mlid_kinds, only: wp
  use mlid_rls, only: rls_settings_t, rls_run
  implicit none
  private
  public :: mlid_rls

contains

  !> Recursive least squares (mlid_rls) of y(n) on the regressors x(np, n)
  !> from theta0 with forgetting factor lambda, P0 = p0 I and the bound
  !> p_max on trace(P)/np (0: none): the estimate and sigma after each sample.
  subroutine mlid_rls(np, n, x, y, theta0, lambda, p0, p_max, theta, sigma, status, msg)
    integer(c_int), intent(in) :: np, n
    real(c_double), intent(in) :: x(np, n), y(n), theta0(np), lambda, p0, p_max
    real(c_double), intent(out) :: theta(np, n), sigma(np, n)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(rls_settings_t) :: s
    integer :: st
    s = rls_settings_t(lambda, p0, p_max)
    call rls_run(x, y, theta0, s, theta, sigma, st, msg)
    status = st
  end subroutine mlid_rls

end module mlid_api_online
