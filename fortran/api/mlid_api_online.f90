!> The flat interface's online (recursive) estimation.  Recursive least
!> squares takes its few arrays directly (a regression, not a model).
!> Conventions: mlid_api_deck's comment.
module mlid_api_online
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use mlid_kinds, only: wp, MLID_ERR_INPUT
  use mlid_rls, only: rls_settings_t, rls_run
  use mlid_ftr, only: ftr_settings_t, ftr_run
  implicit none
  private
  public :: mlid_rls, mlid_ftr

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

  !> Fourier-transform regression (mlid_ftr) of the measured states x(nx, n)
  !> and inputs u(nu, n) at the times t(n) over the frequencies w(nw)
  !> [rad/s], a solve every `every` samples (m = n/every solves), the trim
  !> from the first `trim` samples, the transforms from sample `first`:
  !> each solve's time ts(m), estimates est(np, m) and sigma sig(np, m),
  !> np = nx (nx + nu), equation by equation.
  subroutine mlid_ftr(nx, nu, n, nw, m, t, x, u, w, every, trim, first, ts, est, sig, status, &
                      msg)
    integer(c_int), intent(in) :: nx, nu, n, nw, m, every, trim, first
    real(c_double), intent(in) :: t(n), x(nx, n), u(nu, n), w(nw)
    real(c_double), intent(out) :: ts(m), est(nx*(nx + nu), m), sig(nx*(nx + nu), m)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(ftr_settings_t) :: s
    integer :: st
    ts = 0.0_wp
    est = 0.0_wp
    sig = 0.0_wp
    if (every < 1 .or. m /= n/max(every, 1)) then
      status = MLID_ERR_INPUT
      msg = 'Fourier-transform regression: the solve interval must be >= 1 sample (room for '// &
            'n/every solves)'
      return
    end if
    s%w = w
    s%every = every
    s%trim = trim
    s%first = first
    call ftr_run(t, x, u, s, ts, est, sig, st, msg)
    status = st
  end subroutine mlid_ftr

end module mlid_api_online
