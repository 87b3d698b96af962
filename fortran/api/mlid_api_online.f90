!> The flat interface's online (recursive) estimation.  Recursive least
!> squares takes its few arrays directly (a regression, not a model); the
!> estimators on a record take the handle alone (mlid_api_frequency's
!> comment).  Conventions: mlid_api_deck's comment.
module mlid_api_online
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use mlid_kinds, only: wp, MLID_OK
  use mlid_handles, only: session_t, call_session
  use mlid_problem, only: problem_needs, PART_RECORD
  use mlid_rls, only: rls_settings_t, rls_run
  use mlid_ftr, only: ftr_settings_t, ftr_run
  use mlid_online_history, only: convergence_times
  implicit none
  private
  public :: mlid_rls, mlid_ftr, mlid_convergence_times

  real(wp), parameter :: PI = 4.0_wp*atan(1.0_wp)

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

  !> Fourier-transform regression (mlid_ftr) on the record of handle h
  !> (mlid_api_problem: one manoeuvre, its outputs the measured states x)
  !> with its given values (mlid_api_values): frequencies (Hz), every
  !> (samples between solves), trim (samples whose mean is the trim), first
  !> (the first sample in the transforms), forgetting (lambda, 1: none).  Results: t_solve (m) each
  !> solve's time, estimates and sigma (nx (nx + nu), m), equation by
  !> equation (F's row, then G's), residual_variance (nx, m) each
  !> equation's, m = n/every.
  subroutine mlid_ftr(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: ses
    type(ftr_settings_t) :: s
    real(wp), allocatable :: hz(:), ts(:), est(:, :), sig(:, :), s2(:, :)
    integer :: m, np

    call call_session(h, ses, status, msg)
    if (status /= MLID_OK) return
    call problem_needs(ses%problem, [PART_RECORD], status, msg)
    if (status /= MLID_OK) return
    associate (p => ses%problem, g => ses%given)
      call g%get('frequencies', hz, status, msg)
      call g%get('every', s%every, status, msg)
      call g%get('trim', s%trim, status, msg)
      call g%get('first', s%first, status, msg)
      call g%get('forgetting', s%lambda, status, msg)
      if (status /= MLID_OK) return
      s%w = 2.0_wp*PI*hz
      m = 0
      if (s%every >= 1) m = size(p%t)/s%every
      np = size(p%y, 1)*(size(p%y, 1) + size(p%u, 1))
      allocate (ts(m), est(np, m), sig(np, m), s2(size(p%y, 1), m))
      call ftr_run(p%t, p%y, p%u, s, ts, est, sig, s2, status, msg)
    end associate
    if (status /= MLID_OK) return
    call ses%results%put('t_solve', ts)
    call ses%results%put('estimates', est)
    call ses%results%put('sigma', sig)
    call ses%results%put('residual_variance', s2)
  end subroutine mlid_ftr

  !> When each of np estimates (est(np, n) at the times t(n), sigma sig)
  !> converged: from then on within width times its final sigma of its
  !> final value (mlid_online_history), NaN without a final sigma.
  subroutine mlid_convergence_times(np, n, t, est, sig, width, tc)
    integer(c_int), intent(in) :: np, n
    real(c_double), intent(in) :: t(n), est(np, n), sig(np, n), width
    real(c_double), intent(out) :: tc(np)
    tc = convergence_times(t, est, sig, width)
  end subroutine mlid_convergence_times

end module mlid_api_online
