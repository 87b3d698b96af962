!> The flat interface's online (recursive) estimation.  Recursive least
!> squares takes its few arrays directly (a regression, not a model); the
!> estimators on a record take the handle alone (mlid_api_frequency's
!> comment); the augmented-state filters (mlid_online_filter) take a call
!> handle's model, parameters, record and options (mlid_api_problem).
!> Conventions: mlid_api_deck's comment.
module mlid_api_online
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_MEMORY
  use mlid_problem, only: problem_needs, PART_RECORD
  use mlid_rls, only: rls_settings_t, rls_run
  use mlid_ftr, only: ftr_settings_t, ftr_run
  use mlid_online_history, only: convergence_times
  use mlid_models, only: model_t, layout_t, model_layout
  use mlid_options, only: options_t
  use mlid_params, only: param_map_t
  use mlid_setup, only: problem_setup
  use mlid_handles, only: session_t, call_session
  use mlid_named, only: named_t
  use mlid_online_filter, only: filter_settings_t, FORGET_RANGE
  use mlid_online_ekf, only: ekf_run
  use mlid_online_ukf, only: ukf_run
  implicit none
  private
  public :: mlid_rls, mlid_ftr, mlid_convergence_times, mlid_online_filter

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

  !> An augmented-state filter on the problem of handle h: its model at
  !> the parameters given (x0 and the output biases fixed, the noise
  !> inputs' variances q for the augmented-noise UKF), one record (one
  !> manoeuvre), the options' input hold and RK4 substeps; the problem's
  !> own free set is not used.  Given values (mlid_api_values): method (1
  !> EKF, 2 UKF, 3 the augmented-noise UKF, 4 the EKF as extended
  !> forgetting-factor least squares, forget its lambda); ifree, the free
  !> model parameters (indices into theta's first block p); p0, q (nx +
  !> nf): xa's start and process-noise variances, states first; r (ny); ut
  !> = (alpha, beta, kappa) and kappa_given (0: kappa = 3 - N); delta (> 0:
  !> the EKF's Jacobians by central differences); r_fade (in (0, 1): R
  !> adapted with this fading memory, 0: r given).  Results: est and sig
  !> (nx + nf, nt), xa and its sigma after each sample; rhist (ny, nt), R's
  !> diagonal after each.
  subroutine mlid_online_filter(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: se
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    type(filter_settings_t) :: fs
    integer, allocatable :: ifree(:)
    integer :: method, st

    call call_session(h, se, status, msg)
    if (status /= MLID_OK) return
    associate (p => se%problem, g => se%given)
      call problem_setup(p, m, opt, pm, st, msg)
      if (st == MLID_OK) call g%get('method', method, st, msg)
      if (st == MLID_OK) call g%get('ifree', ifree, st, msg)
      if (st == MLID_OK) call given_settings(g, m, size(ifree), opt, fs, st, msg)
      if (st == MLID_OK .and. method == 4) call g%get('forget', fs%forget, st, msg)
      status = st
      if (st /= MLID_OK) return
      status = MLID_ERR_INPUT
      if (method < 1 .or. method > 4) then
        msg = 'online filter method must be 1 (EKF), 2 (UKF), 3 (augmented-noise UKF) or 4 '// &
              '(EFRLS)'
      else if (method == 4 .and. .not. (fs%forget > 0.0_wp .and. fs%forget <= 1.0_wp)) then
        msg = FORGET_RANGE
      else if (size(p%segstart) /= 1) then
        msg = 'the online filters run on one record: join the manoeuvres into one'
      else
        call run_filter(m, method, ifree, fs, p%theta, p%t, p%u, p%y, se%results, st, msg)
        status = st
      end if
    end associate
  end subroutine mlid_online_filter

  !> The filter settings from the given values and the options.
  subroutine given_settings(g, m, nf, opt, fs, status, msg)
    type(named_t), intent(in) :: g
    class(model_t), intent(in) :: m
    integer, intent(in) :: nf
    type(options_t), intent(in) :: opt
    type(filter_settings_t), intent(out) :: fs
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    real(wp), allocatable :: ut(:)
    integer :: kappa_given
    call g%get('p0', fs%p0, status, msg, [m%nx + nf])
    call g%get('q', fs%q, status, msg, [m%nx + nf])
    call g%get('r', fs%r, status, msg, [m%ny])
    call g%get('ut', ut, status, msg, [3])
    call g%get('kappa_given', kappa_given, status, msg)
    call g%get('delta', fs%delta, status, msg)
    call g%get('r_fade', fs%r_fade, status, msg)
    if (status /= MLID_OK) return
    fs%alpha = ut(1)
    fs%beta = ut(2)
    fs%kappa = ut(3)
    fs%kappa_given = kappa_given /= 0
    fs%hold = opt%hold
    fs%nsub = opt%substeps
  end subroutine given_settings

  !> The filter on the record (t, u, z) from theta's model parameters, x0
  !> and biases; est and sig into the results.
  subroutine run_filter(m, method, ifree, fs, theta, t, u, z, results, status, msg)
    class(model_t), intent(in) :: m
    integer, intent(in) :: method, ifree(:)
    type(filter_settings_t), intent(inout) :: fs
    real(wp), intent(in) :: theta(:), t(:), u(:, :), z(:, :)
    type(named_t), intent(inout) :: results
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: est(:, :), sig(:, :), rhist(:, :)
    type(layout_t) :: l
    integer :: ierr
    allocate (est(m%nx + size(ifree), size(t)), sig(m%nx + size(ifree), size(t)), &
              rhist(m%ny, size(t)), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'online filter: out of memory for the history'
      return
    end if
    l = model_layout(m)
    fs%qw = theta(l%oq + 1:l%oq + m%nw)
    associate (p => theta(1:m%np), x0 => theta(l%ox0 + 1:l%ox0 + m%nx), &
               bias => theta(l%obias + 1:l%obias + m%ny))
      if (method == 1 .or. method == 4) then
        call ekf_run(m, p, ifree, x0, bias, t, u, z, fs, est, sig, rhist, status, msg)
      else
        call ukf_run(m, p, ifree, x0, bias, t, u, z, fs, method == 3, est, sig, rhist, status, &
                     msg)
      end if
    end associate
    if (status /= MLID_OK) return
    call results%put('est', est)
    call results%put('sig', sig)
    call results%put('rhist', rhist)
  end subroutine run_filter

end module mlid_api_online
