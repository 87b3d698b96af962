!> The flat interface's estimation: fit, evaluate, simulate, Monte Carlo,
!> the coloured-residual covariance, and the report and JSON texts of a
!> fit and a validation.
!> Conventions: mlid_api_deck's comment.
module mlid_api_fit
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_MEMORY, MLID_ERR_INTERRUPTED
  use mlid_models, only: model_t
  use mlid_options, only: options_t, frequency_method, NOPT
  use mlid_params, only: param_map_t, apply_ties
  use mlid_likelihood, only: likelihood, sens_keep_t, weighted_sensitivities
  use mlid_newton, only: fit_result_t
  use mlid_fit_driver, only: fit_solve, fit_view
  use mlid_colored, only: colored_covariance, colored_sandwich
  use mlid_simulate, only: simulate_flat
  use mlid_monte_carlo, only: monte_carlo, mc_statistics
  use mlid_setup, only: setup, problem_setup
  use mlid_case, only: NAMELEN
  use mlid_text, only: split_lines
  use mlid_units, only: UNITLEN
  use mlid_report, only: fit_summary_t, fit_report, fit_json, case_json, validation_report, &
                         validation_json
  use mlid_validate, only: prediction_stats
  use mlid_handles, only: session_t, handle_session, call_session
  use mlid_progress, only: progress_t
  use mlid_named, only: named_t, value_t, VALUE_REAL
  use mlid_problem, only: problem_needs, PART_MODEL, PART_PARAMS, PART_RECORD, PART_OPTIONS, &
                          PART_EXTRAS
  use mlid_run, only: put_fit
  implicit none
  private
  public :: mlid_report_fit, mlid_case_json, mlid_prediction_stats, mlid_report_validation, &
            mlid_fit, mlid_evaluate, mlid_colored_cov, mlid_simulate, mlid_monte_carlo, &
            mlid_monte_carlo_summary

contains

  !> The printed report and the JSON object of a fit (the text mlid-batch
  !> prints and writes), from the handle's given values (mlid_api_values):
  !> labels and units (one a line), iopt, ropt, start, est, sig, sigc (sigma
  !> corrected for coloured residuals) and lag (its lag), cov, eigval,
  !> eigvec, rhat, hist, cost, niter, reason, converged, nrank, title, job,
  !> the fit's fit_status and fit_msg, and rnoise (the innovations
  !> criterion's R; NaN: none).  Results: report and json, whole.
  subroutine mlid_report_fit(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: ses
    type(fit_summary_t) :: s
    character(len=:), allocatable :: labels, units, title, job, fit_msg, outputs, output_units
    integer, allocatable :: iopt(:)
    real(wp), allocatable :: ropt(:), rnoise(:)
    integer :: fit_status, converged, nf

    call call_session(h, ses, status, msg)
    if (status /= MLID_OK) return
    associate (g => ses%given)
      call g%get('est', s%est, status, msg)
      nf = size(s%est)
      call g%get('labels', labels, status, msg)
      call g%get('units', units, status, msg)
      call g%get('iopt', iopt, status, msg, [NOPT])
      call g%get('ropt', ropt, status, msg, [NOPT])
      call g%get('start', s%start, status, msg, [nf])
      call g%get('sig', s%sig, status, msg, [nf])
      call g%get('sigc', s%sigc, status, msg, [nf])
      call g%get('lag', s%lag, status, msg)
      call g%get('cov', s%cov, status, msg, [nf, nf])
      call g%get('eigval', s%eigval, status, msg, [nf])
      call g%get('eigvec', s%eigvec, status, msg, [nf, nf])
      call g%get('rhat', s%rhat, status, msg)
      call g%get('rnoise', rnoise, status, msg, [size(s%rhat, 1)])
      call g%get('hist', s%hist, status, msg)
      call g%get('cost', s%cost, status, msg)
      call g%get('niter', s%niter, status, msg)
      call g%get('reason', s%reason, status, msg)
      call g%get('converged', converged, status, msg)
      call g%get('nrank', s%rank, status, msg)
      call g%get('title', title, status, msg)
      call g%get('job', job, status, msg)
      call g%get('fit_status', fit_status, status, msg)
      call g%get('fit_msg', fit_msg, status, msg)
    end associate
    if (status /= MLID_OK) return
    s%converged = converged == 1
    s%labels = split_lines(labels, nf, NAMELEN)
    s%units = split_lines(units, nf, UNITLEN)
    associate (g => ses%given)      ! the outputs' names and units, when the caller has them
      if (g%find('outputs') > 0) then
        call g%get('outputs', outputs, status, msg)
        call g%get('output_units', output_units, status, msg)
        if (status /= MLID_OK) return
        s%outputs = split_lines(outputs, size(s%rhat, 1), 32)
        s%output_units = split_lines(output_units, size(s%rhat, 1), UNITLEN)
      end if
    end associate
    if (all(ieee_is_finite(rnoise))) s%rnoise = rnoise
    call ses%results%put('report', fit_report(s, iopt, ropt, fit_status, fit_msg))
    call ses%results%put('json', fit_json(title, job, fit_status, fit_msg, s, iopt, ropt))
  end subroutine mlid_report_fit

  !> The JSON object of a case without a fit (samples >= 0: a simulate
  !> case that wrote out).
  subroutine mlid_case_json(title, job, status, msg, samples, out, json, njson)
    character(len=*), intent(in) :: title, job, msg, out
    integer(c_int), intent(in) :: status, samples
    character(len=4096), intent(out) :: json
    integer(c_int), intent(out) :: njson
    character(len=:), allocatable :: text
    if (samples >= 0) then
      text = case_json(title, job, status, msg, samples, out)
    else
      text = case_json(title, job, status, msg)
    end if
    njson = min(len(text), len(json))
    json = text
  end subroutine mlid_case_json

  !> Theil's U, rms error and rms/sigma per output of a prediction
  !> (mlid_validate): y, yhat (ny, nt), rhat the identification's.
  subroutine mlid_prediction_stats(ny, nt, y, yhat, rhat, theil, rms, ratio)
    integer(c_int), intent(in) :: ny, nt
    real(c_double), intent(in) :: y(ny, nt), yhat(ny, nt), rhat(ny, ny)
    real(c_double), intent(out) :: theil(ny), rms(ny), ratio(ny)
    call prediction_stats(y, yhat, rhat, theil, rms, ratio)
  end subroutine mlid_prediction_stats

  !> The printed lines and the JSON member of a validation, from the
  !> handle's given values (mlid_api_values): names and units (the unit each
  !> output is shown in; one a line), scale (core = scale*shown), holdout,
  !> theil, rms and ratio (core units).  Results: report and json, whole.
  subroutine mlid_report_validation(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: ses
    character(len=:), allocatable :: names, units
    integer, allocatable :: holdout(:)
    real(wp), allocatable :: scale(:), theil(:), rms(:), ratio(:)
    integer :: ny

    call call_session(h, ses, status, msg)
    if (status /= MLID_OK) return
    associate (g => ses%given)
      call g%get('theil', theil, status, msg)
      ny = size(theil)
      call g%get('names', names, status, msg)
      call g%get('units', units, status, msg)
      call g%get('scale', scale, status, msg, [ny])
      call g%get('holdout', holdout, status, msg)
      call g%get('rms', rms, status, msg, [ny])
      call g%get('ratio', ratio, status, msg, [ny])
    end associate
    if (status /= MLID_OK) return
    call ses%results%put('report', validation_report(split_lines(names, ny, NAMELEN), &
                         split_lines(units, ny, UNITLEN), scale, holdout, theil, rms, ratio))
    call ses%results%put('json', validation_json(split_lines(names, ny, NAMELEN), holdout, &
                         theil, rms, ratio))
  end subroutine mlid_report_validation

  !> Maximum-likelihood fit of the problem of handle h (mlid_api_problem:
  !> model, params, record, options, and the extras when they were set for
  !> this fit: a fit takes them away), output or filter error
  !> (iopt(6)), with the options of report sec. 4.6: a priori values and
  !> weight over the free parameters, bounds, the rank-deficient search from
  !> iopt(10).  What it gives is the handle's results by name, as a deck
  !> case's fit keeps them (mlid_run's put_fit): theta_start (theta0, or the
  !> equation-error start-up's values), theta, sigma (Cramer-Rao, 0 for
  !> fixed), covariance, information, gradient, eigenvalues, eigenvectors
  !> over the free parameters, rhat (R-hat, or the mean innovation
  !> covariance), yhat, cost_history (max_iter + 1; entries past iterations
  !> + 1 are 0), cost, iterations, reason (mlid_kinds STOP_*), converged,
  !> rank (of the last step), bad_param (free index of a singular
  !> direction), sigma_corrected and covariance_corrected (for coloured
  !> residuals, mlid_colored) and colored_lag, r_innovations, status and
  !> message.  Several manoeuvres: the record holds them one after the
  !> other, segment k from sample segstart(k) (segstart(1) = 1), with an
  !> initial state and a bias vector each in theta (the x0 and bias blocks
  !> nseg times as long).  p: a handle whose progress counts the Newton
  !> iterations while the fit runs (mlid_api_deck's mlid_progress_get), or 0.
  subroutine mlid_fit(h, p, status, msg)
    integer(c_int64_t), intent(in) :: h, p
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s, ps
    type(progress_t), pointer :: counter
    type(fit_result_t) :: res
    type(param_map_t) :: pm
    type(options_t) :: opt
    integer :: bad

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    counter => null()
    if (p /= 0) then
      call handle_session(p, ps, status, msg)
      if (status /= MLID_OK) return
      counter => ps%progress
    end if
    associate (p => s%problem)
      call problem_needs(p, [PART_MODEL, PART_PARAMS, PART_RECORD, PART_OPTIONS], status, msg)
      if (status /= MLID_OK) return
      if (.not. p%has(PART_EXTRAS)) then   ! none set for this fit: none
        p%use_prior = 0
        p%use_bounds = 0
        p%prior = [real(wp) ::]
        p%pweight = reshape([real(wp) ::], [0, 0])
        p%lower = p%prior
        p%upper = p%prior
      end if
      p%has(PART_EXTRAS) = .false.         ! the extras are the next fit's alone
      ! counter null: no progress argument (a disassociated pointer is an absent optional)
      call fit_solve(p%mkind, p%nx, p%nu, p%ny, p%nw, p%theta, p%isfree, p%tie, p%iconst, &
                     p%rconst, p%t, p%u, p%y, p%segstart, p%iopt, p%ropt, count(p%isfree > 0), &
                     p%use_prior, p%prior, p%pweight, p%use_bounds, p%lower, p%upper, res, pm, &
                     opt, bad, status, msg, counter)
      ! out of memory or interrupted: nothing to view (a long record's view
      ! needs the memory that was missing), the status says it
      if (status == MLID_ERR_MEMORY .or. status == MLID_ERR_INTERRUPTED) return
      call put_fit(s%results, fit_view(res, pm, opt, p%theta, p%ny, size(p%t), bad), status, msg)
    end associate
  end subroutine mlid_fit

  !> Cost, gradient, information matrix and output sensitivity norms at
  !> the parameters of the problem of handle h (model, params, record and
  !> options), without iterating.  Results by name: cost, gradient (nf),
  !> information (nf, nf), rhat (ny, ny), yhat (ny, nt), sensitivity (ny,
  !> nf), weighted_sensitivity (ny, nt, nf) and information_sensitivity
  !> (nf, nf), the last two the inputs of mlid_colored_cov.
  subroutine mlid_evaluate(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    type(sens_keep_t) :: keep
    real(wp), allocatable :: th(:), grad(:), info(:, :), rhat(:, :), sens(:, :), msens(:, :)
    type(value_t), target :: vyhat, vwsens       ! the large ones, written in place
    real(wp), pointer :: yhat(:, :), wsens(:, :, :)
    real(wp) :: cost
    integer :: nf, ny, nt

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    associate (p => s%problem)
      call problem_setup(p, m, opt, pm, status, msg)
      if (status /= MLID_OK) return
      nf = pm%nf
      if (frequency_method(opt)) then
        status = MLID_ERR_INPUT
        msg = 'evaluate works on the time-domain record: the frequency-domain methods have '// &
              'frequency_evaluate'
        return
      end if
      ny = p%ny
      nt = size(p%t)
      allocate (grad(nf), info(nf, nf), rhat(ny, ny), sens(ny, nf), msens(nf, nf), source=0.0_wp)
      call real_value(vyhat, 'yhat', [ny, nt])
      call real_value(vwsens, 'weighted_sensitivity', [ny, nt, nf])
      yhat(1:ny, 1:nt) => vyhat%r
      wsens(1:ny, 1:nt, 1:nf) => vwsens%r
      th = p%theta
      call apply_ties(pm%tie, th)
      ! wsens made as a fit makes it at its estimate: from what the evaluation keeps
      call likelihood(m, th, pm, p%t, p%u, p%y, opt, cost, rhat, yhat, status, msg, grad, info, &
                      sens, msens, keep=keep)
    end associate
    if (status /= MLID_OK) return
    if (allocated(keep%dy)) call weighted_sensitivities(keep, pm%l%seg, wsens)
    call s%results%put('cost', cost)
    call s%results%put('gradient', grad)
    call s%results%put('information', info)
    call s%results%put('rhat', rhat)
    call s%results%put_value(vyhat)
    call s%results%put('sensitivity', sens)
    call s%results%put_value(vwsens)
    call s%results%put('information_sensitivity', msens)
  end subroutine mlid_evaluate

  !> The covariance corrected for coloured residuals (mlid_colored), from
  !> the handle's given values: weighted sensitivities a (ny, nt, nf), the
  !> segment starts segstart, cov (M^-1), info (M) and msens (the part of M
  !> a makes), and either the residual autocovariance rvv (ny, ny, nlag+1:
  !> rvv(:, :, k+1) = Rvv(k), Bartlett weights at nlag) or the residuals v
  !> (ny, nt) and the lag to go to (< 0: chosen from v).  Results:
  !> covariance_corrected (nf, nf) and lag, the lag used.
  subroutine mlid_colored_cov(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    real(wp), allocatable :: a(:, :, :), v(:, :), rvv(:, :, :), cov(:, :), info(:, :), &
                             msens(:, :), cov_c(:, :)
    integer, allocatable :: segstart(:)
    integer :: nf, lag_in, lag

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    associate (g => s%given)
      call get_real3(g, 'a', a, status, msg)
      nf = size(a, 3)
      call g%get('segstart', segstart, status, msg)
      call g%get('cov', cov, status, msg, [nf, nf])
      call g%get('info', info, status, msg, [nf, nf])
      call g%get('msens', msens, status, msg, [nf, nf])
      if (g%find('rvv') > 0) then
        call get_real3(g, 'rvv', rvv, status, msg)
        if (status /= MLID_OK) return
        allocate (cov_c(nf, nf))
        lag = size(rvv, 3) - 1
        call colored_sandwich(cov, info, msens, a, rvv, segstart, cov_c, status, msg)
      else
        call g%get('v', v, status, msg)
        call g%get('lag', lag_in, status, msg)
        if (status /= MLID_OK) return
        allocate (cov_c(nf, nf))
        call colored_covariance(cov, info, msens, a, v, segstart, lag_in, cov_c, lag, status, msg)
      end if
    end associate
    if (status /= MLID_OK) return
    call s%results%put('covariance_corrected', cov_c)
    call s%results%put('lag', lag)
  end subroutine mlid_colored_cov

  !> Outputs y and states x of the model of handle h (model, params: theta,
  !> its free set and ties not used; record: times and inputs, its outputs
  !> not used; options) with the process and measurement noise whose
  !> statistics are in theta, drawn from seed; timing 0 or 1 (forward or
  !> backward, mlid_simulate).  ny, nx and nt: the problem's.  seed and
  !> timing are arguments, not given values: two values by name cost a
  !> call 4-5 us, a tenth of a C-8 simulation.
  subroutine mlid_simulate(h, seed, timing, ny, nx, nt, y, x, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: seed, timing, ny, nx, nt
    real(c_double), intent(out) :: y(ny, nt), x(nx, nt)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s

    y = 0.0_wp
    x = 0.0_wp
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    s%results = named_t()             ! what it gives are its arguments
    associate (p => s%problem)
      call problem_needs(p, [PART_MODEL, PART_PARAMS, PART_RECORD, PART_OPTIONS], status, msg)
      if (status /= MLID_OK) return
      if (ny /= p%ny .or. nx /= p%nx .or. nt /= size(p%t)) then
        status = MLID_ERR_INPUT
        write (msg, '(a,3(1x,i0),a,3(1x,i0))') 'simulate: outputs for ny, nx, nt =', ny, nx, nt, &
          '; the problem has', p%ny, p%nx, size(p%t)
        return
      end if
      call simulate_flat(p%mkind, p%nx, p%nu, p%ny, p%nw, p%theta, p%iconst, p%rconst, p%t, p%u, &
                         p%iopt, p%ropt, seed, y, x, status, msg, timing)
    end associate
  end subroutine mlid_simulate

  !> nrun identifications of the problem of handle h (model, params: the
  !> start values, free set and ties; record: times and inputs, its outputs
  !> not used; options): data from the given theta_true with seeds seed0,
  !> seed0+1, ..., each fitted from the start.  Results by name: estimates
  !> and sigma (nf, nrun), the estimates and Cramer-Rao standard deviations
  !> of the free parameters, information (nf, nf, nrun), iterations and
  !> run_status (nrun: 0, or the code the run ended on).
  subroutine mlid_monte_carlo(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    real(wp), allocatable :: theta_true(:), est(:, :), sig(:, :)
    integer, allocatable :: iters(:), run_status(:)
    type(value_t), target :: vinfo      ! the large one, written in place
    real(wp), pointer :: info(:, :, :)
    integer :: seed0, nrun, nf

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    associate (p => s%problem, g => s%given)
      call problem_needs(p, [PART_MODEL, PART_PARAMS, PART_RECORD, PART_OPTIONS], status, msg)
      if (status /= MLID_OK) return
      call g%get('theta_true', theta_true, status, msg, [size(p%theta)])
      call g%get('seed0', seed0, status, msg)
      call g%get('nrun', nrun, status, msg)
      if (status /= MLID_OK) return
      nf = count(p%isfree > 0)
      call setup(p%mkind, p%nx, p%nu, p%ny, p%nw, p%theta, p%isfree, p%tie, p%iconst, p%rconst, &
                 p%t, p%u, p%y, p%iopt, p%ropt, nf, m, opt, pm, status, msg)
      if (status /= MLID_OK) return
      if (.not. all(ieee_is_finite(theta_true))) then
        status = MLID_ERR_INPUT
        msg = 'true parameter values must be finite'
        return
      end if
      allocate (est(nf, nrun), sig(nf, nrun), iters(nrun), run_status(nrun))
      run_status = 0
      call real_value(vinfo, 'information', [nf, nf, nrun])
      info(1:nf, 1:nf, 1:nrun) => vinfo%r
      call monte_carlo(m, theta_true, p%theta, pm, p%t, p%u, opt, seed0, est, sig, iters, &
                       run_status, info)
    end associate
    call s%results%put('estimates', est)
    call s%results%put('sigma', sig)
    call s%results%put_value(vinfo)
    call s%results%put('iterations', iters)
    call s%results%put('run_status', run_status)
  end subroutine mlid_monte_carlo

  !> The statistics of Monte Carlo runs (mlid_monte_carlo's mc_statistics,
  !> those of the deck job too) from the given est and sig (nf, nrun), info
  !> (nf, nf, nrun) and run_status (nrun), over the runs with run_status 0.
  !> Results: runs (their number), mean, sample_sigma and mean_cr_sigma of
  !> each free parameter (nf), sample_cov_trace, sample_cov_det,
  !> mean_info_trace and mean_info_det; NaN where too few runs.
  subroutine mlid_monte_carlo_summary(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    real(wp), allocatable :: est(:, :), sig(:, :), info(:, :, :), mean(:), sample_sigma(:), &
                             cr_sigma(:)
    integer, allocatable :: run_status(:)
    real(wp) :: stats(4)
    integer :: nok

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    associate (g => s%given)
      call g%get('est', est, status, msg)
      call g%get('sig', sig, status, msg, shape(est))
      call get_real3(g, 'info', info, status, msg, [size(est, 1), size(est, 1), size(est, 2)])
      call g%get('run_status', run_status, status, msg, [size(est, 2)])
    end associate
    if (status /= MLID_OK) return
    allocate (mean(size(est, 1)), sample_sigma(size(est, 1)), cr_sigma(size(est, 1)))
    call mc_statistics(est, sig, info, run_status, nok, mean, sample_sigma, cr_sigma, stats(1), &
                       stats(2), stats(3), stats(4))
    call s%results%put('runs', nok)
    call s%results%put('mean', mean)
    call s%results%put('sample_sigma', sample_sigma)
    call s%results%put('mean_cr_sigma', cr_sigma)
    call s%results%put('sample_cov_trace', stats(1))
    call s%results%put('sample_cov_det', stats(2))
    call s%results%put('mean_info_trace', stats(3))
    call s%results%put('mean_info_det', stats(4))
  end subroutine mlid_monte_carlo_summary

  !> v: real value name of shape shp, zero, to be written through a pointer
  !> of that shape and moved into the results (no copy of a large one).
  subroutine real_value(v, name, shp)
    type(value_t), intent(out) :: v
    character(len=*), intent(in) :: name
    integer, intent(in) :: shp(:)
    v%name = name
    v%kind = VALUE_REAL
    v%rank = size(shp)
    v%shape = 1
    v%shape(1:size(shp)) = shp
    allocate (v%r(product(shp)), source=0.0_wp)
  end subroutine real_value

  !> Value name of g as x (rank 3, of shape shp when given), as named_t's
  !> get (which goes to rank 2).
  subroutine get_real3(g, name, x, status, msg, shp)
    type(named_t), intent(in) :: g
    character(len=*), intent(in) :: name
    real(wp), allocatable, intent(out) :: x(:, :, :)
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    integer, intent(in), optional :: shp(3)
    integer :: k
    if (status /= MLID_OK) return
    k = g%found(name, VALUE_REAL, 3, status, msg, shp)
    if (k > 0) then
      x = reshape(g%v(k)%r, g%v(k)%shape)
    else
      allocate (x(0, 0, 0))
    end if
  end subroutine get_real3

end module mlid_api_fit
