!> The fit driver: a fit from its flat description (model kind and sizes,
!> parameters and which are free, ties, constants, record, options), with
!> its a priori values and bounds checked, run by the method the options
!> name.  The one way in to a fit for the job runner (mlid_run) and the
!> flat interface (mlid_api_fit's mlid_fit) alike.
module mlid_fit_driver
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan, ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_SINGULAR, MLID_ERR_NOCONV, &
                        MLID_ERR_INTERNAL
  use mlid_models, only: model_t
  use mlid_options, only: options_t, frequency_method, METHOD_FILTER_ERROR
  use mlid_frequency, only: freq_record
  use mlid_likelihood, only: weighted_sensitivities
  use mlid_colored, only: colored_covariance
  use mlid_text, only: itoa, es_text
  use mlid_memory, only: no_memory
  use mlid_params, only: param_map_t, tie_t
  use mlid_linalg, only: sym_eig
  use mlid_setup, only: setup
  use mlid_newton, only: fit_result_t, extras_t, newton_fit
  use mlid_progress, only: progress_t, progress_start, progress_stop
  implicit none
  private
  public :: fit_solve, fit_method, fit_view_t, fit_view

  !> Exact ML: an r(i) below this of its output's innovation variance looks
  !> noise-free (the likelihood has no maximum as r(i) -> 0) ...
  real(wp), parameter :: NOISE_FREE_RATIO = 1.0e-4_wp
  !> ... and what to do then.
  character(len=*), parameter :: NOISE_FREE_REMEDY = 'fix those r at a floor or use '// &
    'noise_criterion = ''innovations'''

  !> A fit as its callers see it: every parameter (fixed ones as given),
  !> sigma over every parameter (0 where fixed), the matrices over the free
  !> ones.  What the fit did not reach is zero (no information matrix: no
  !> statistics, iterations 0); r_innovations NaN unless the innovations
  !> criterion set it.
  type :: fit_view_t
    real(wp), allocatable :: theta_start(:), theta(:), sigma(:), sigma_c(:)
    real(wp), allocatable :: cov(:, :), cov_c(:, :), info(:, :), grad(:), eigval(:), eigvec(:, :)
    real(wp), allocatable :: rhat(:, :), yhat(:, :), hist(:), rnoise(:)
    real(wp), allocatable :: kc(:)   !< the textbook gain's diag(KC) (empty for other criteria)
    real(wp) :: cost = 0.0_wp
    integer :: niter = 0, reason = 0, rank = 0, bad = 0, lag = 0
    logical :: converged = .false.
  end type fit_view_t

contains

  !> Fit the free parameters of theta0 (isfree) of the model mkind to the
  !> record t, u, y (manoeuvres from segstart).  use_prior, prior, pweight:
  !> the a priori values and weight (report §4.6); use_bounds, lower,
  !> upper: the bounds (over all parameters; those of the free ones are
  !> used).  res holds the fit (its last iterate when status says it
  !> failed), pm the parameter map, opt the options; bad names the free
  !> parameter a message of the checks is about (0 none; a singular fit's
  !> is res%bad_param).  msg of a good fit is the
  !> set-up's warning, else the fit's note.  progress counts the Newton
  !> iterations (mlid_progress; the budget max_iter as its ceiling).
  subroutine fit_solve(mkind, nx, nu, ny, nw, theta0, isfree, tie, iconst, rconst, t, u, y, &
                       segstart, iopt, ropt, nf, use_prior, prior, pweight, use_bounds, lower, &
                       upper, res, pm, opt, bad, status, msg, progress)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nf, use_prior, use_bounds
    real(c_double), intent(in) :: theta0(:), rconst(:), t(:), u(:, :), y(:, :)
    integer(c_int), intent(in) :: isfree(:), iconst(:), segstart(:)
    type(tie_t), intent(in) :: tie
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16), prior(:), pweight(:, :), lower(:), upper(:)
    type(fit_result_t), intent(out) :: res
    type(param_map_t), intent(out) :: pm
    type(options_t), intent(out) :: opt
    integer, intent(out) :: bad, status
    character(len=*), intent(out) :: msg
    type(progress_t), intent(inout), target, optional :: progress
    class(model_t), allocatable :: m
    type(extras_t) :: ex
    character(len=len(msg)) :: warning

    bad = 0
    call setup(mkind, nx, nu, ny, nw, theta0, isfree, tie, iconst, rconst, t, u, y, iopt, ropt, &
               nf, m, opt, pm, status, msg, segstart)
    if (status /= MLID_OK) return
    warning = msg
    call fit_extras(pm, opt, theta0, use_prior, prior, pweight, use_bounds, lower, upper, ex, &
                    bad, status, msg)
    if (status /= MLID_OK) return
    if (present(progress)) ex%progress => progress
    call progress_start(progress, 'fit', opt%max_iter, .false.)
    call fit_method(m, theta0, pm, t, u, y, opt, ex, res, status, msg)
    call progress_stop(progress)
    if (status /= MLID_OK) return
    msg = warning
    if (len_trim(warning) == 0) msg = res%note
  end subroutine fit_solve

  !> Fit by the method of opt: a frequency-domain method on the record's
  !> transforms (made once, mlid_frequency), the Newton search (mlid_newton)
  !> on what the method sees; then what the method adds to the search's
  !> result: the bound corrected for coloured residuals in the time domain
  !> (left out with plain_bound, for a caller that keeps only res%cov: the
  !> Monte Carlo), and filter error's noise-free outputs named.
  subroutine fit_method(m, theta0, pm, t, u, y, opt, ex, res, status, msg, plain_bound)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta0(:), t(:), u(:, :), y(:, :)
    type(param_map_t), intent(in) :: pm
    type(options_t), intent(in) :: opt
    type(extras_t), intent(in) :: ex
    type(fit_result_t), intent(out) :: res
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    logical, intent(in), optional :: plain_bound
    real(wp), allocatable :: tf(:), uf(:, :), yf(:, :)
    logical :: colored

    if (frequency_method(opt)) then
      call freq_record(m, theta0, pm, t, u, y, opt, tf, uf, yf, status, msg)
      if (status /= MLID_OK) return
      call newton_fit(m, theta0, pm, tf, uf, yf, opt, ex, res, status, msg)
    else
      call newton_fit(m, theta0, pm, t, u, y, opt, ex, res, status, msg)
    end if
    if (.not. res%started) return
    if (.not. res%searched) then
      call noise_free_outputs(opt, pm, ex, res, msg)
      return
    end if
    if (opt%noise_criterion == 1) then
      if (frequency_method(opt)) then
        call noise_free_note(pm, size(tf), res)
      else
        call noise_free_note(pm, size(t), res)
      end if
    end if
    if (opt%noise_criterion == 0 .and. opt%method == METHOD_FILTER_ERROR) &
      call noise_free_warning(pm, ex, res)
    colored = .true.
    if (present(plain_bound)) colored = .not. plain_bound
    if (frequency_method(opt) .and. allocated(res%cov)) then
      res%cov_c = res%cov     ! no coloured-residual correction in the frequency domain
    else if (colored .and. any(status == [MLID_OK, MLID_ERR_NOCONV, MLID_ERR_SINGULAR])) then
      call colored_bound(pm, y, res, status, msg)
    end if
    if (status /= MLID_OK) call noise_free_outputs(opt, pm, ex, res, msg)
  end subroutine fit_method

  !> The Cramer-Rao covariance corrected for coloured residuals
  !> (mlid_colored) from the weighted sensitivities of the last information
  !> matrix's evaluation, made here from what it kept; a failure there
  !> replaces only an OK status.
  subroutine colored_bound(pm, y, res, status, msg)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: y(:, :)
    type(fit_result_t), intent(inout) :: res
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    real(wp), allocatable :: wsens(:, :, :), v(:, :)
    integer :: cstat, ist
    character(len=len(msg)) :: cmsg

    allocate (res%cov_c(pm%nf, pm%nf))
    res%cov_c = res%cov
    allocate (wsens(size(y, 1), size(y, 2), pm%nf), stat=ist)   ! nf times the record
    if (ist /= 0) then
      call no_memory('the weighted sensitivities of '//itoa(size(y, 2))//' samples x '// &
                     itoa(pm%nf)//' parameters', real(size(y), wp)*pm%nf, cstat, cmsg)
      if (status == MLID_OK) then
        status = cstat
        msg = cmsg
      end if
      return
    end if
    if (.not. kept(res)) then            ! (no path gets here without them: a guard)
      if (status == MLID_OK) then
        status = MLID_ERR_INTERNAL
        msg = 'coloured-residual correction: the estimate''s sensitivities were not kept'
      end if
      return
    end if
    call weighted_sensitivities(res%keep, pm%l%seg, wsens)
    allocate (v(size(y, 1), size(y, 2)), stat=ist)   ! the residuals: a record's length
    if (ist /= 0) then
      call no_memory('the residuals of '//itoa(size(y, 2))//' samples', real(size(y), wp), &
                     cstat, cmsg)
    else
      v = y - res%yhat
      call colored_covariance(res%cov, res%info, res%msens, wsens, v, pm%l%seg, -1, &
                              res%cov_c, res%lag, cstat, cmsg)
    end if
    if (cstat /= MLID_OK .and. status == MLID_OK) then
      status = cstat
      msg = cmsg
    end if
  end subroutine colored_bound

  !> Whether res holds its evaluation's sensitivities and weights.
  logical function kept(res)
    type(fit_result_t), intent(in) :: res
    kept = .false.
    if (.not. allocated(res%keep)) return
    kept = allocated(res%keep%dy) .and. allocated(res%keep%w)
  end function kept

  !> A filter-error fit with R free that fails with some r(i) far below its
  !> output's innovation variance, or fallen a hundredfold from its start:
  !> those outputs carry (almost) no measurement noise, and exact ML has no
  !> maximum there (the likelihood grows as r(i) -> 0).  The message then
  !> says so, and names them and the remedies, in place of the symptom (a
  !> singular B or information matrix); short enough for the interfaces'
  !> 256 characters with the symptom.
  subroutine noise_free_outputs(opt, pm, ex, res, msg)
    type(options_t), intent(in) :: opt
    type(param_map_t), intent(in) :: pm
    type(extras_t), intent(in) :: ex
    type(fit_result_t), intent(in) :: res
    character(len=*), intent(inout) :: msg
    character(len=len(msg)) :: names

    if (opt%method /= METHOD_FILTER_ERROR .or. .not. allocated(res%rhat) .or. &
        .not. allocated(res%theta) .or. &
        .not. allocated(res%theta_start)) return
    names = noise_free_names(pm, ex, res, .true.)
    if (len_trim(names) > 0) msg = trim(names)//'; '//NOISE_FREE_REMEDY//' ('//trim(msg)//')'
  end subroutine noise_free_outputs

  !> A filter-error fit with R free that ends with some r(i) far below its
  !> output's innovation variance: it stopped on the slope of a likelihood
  !> without maximum, which res%note says, with the remedies.
  subroutine noise_free_warning(pm, ex, res)
    type(param_map_t), intent(in) :: pm
    type(extras_t), intent(in) :: ex
    type(fit_result_t), intent(inout) :: res
    character(len=len(res%note)) :: names
    names = noise_free_names(pm, ex, res, .false.)
    if (len_trim(names) > 0) res%note = 'warning: '//trim(names)//'; '//NOISE_FREE_REMEDY
  end subroutine noise_free_warning

  !> 'outputs r(1), r(4) look noise-free (r/B <= 5.7E-05): exact ML has no
  !> maximum' for the free r(i) below NOISE_FREE_RATIO of their innovation
  !> variance (with fall: or below NOISE_FREE_FALL of their start), leaving
  !> out those on a lower bound the user set; '' when there are none.
  function noise_free_names(pm, ex, res, fall) result(text)
    type(param_map_t), intent(in) :: pm
    type(extras_t), intent(in) :: ex
    type(fit_result_t), intent(in) :: res
    logical, intent(in) :: fall
    character(len=256) :: text
    real(wp), parameter :: NOISE_FREE_FALL = 1.0e-2_wp
    real(wp) :: worst, r
    logical :: low
    integer :: k, i

    text = ''
    worst = 0.0_wp
    do k = 1, pm%nf
      i = pm%ifree(k) - pm%l%or
      if (i < 1 .or. i > size(res%rhat, 1)) cycle
      r = res%theta(pm%ifree(k))
      low = r < NOISE_FREE_RATIO*res%rhat(i, i)
      if (fall) low = low .or. r < NOISE_FREE_FALL*res%theta_start(pm%ifree(k))
      if (.not. low) cycle
      if (allocated(ex%lower)) then
        if (r <= ex%lower(k)*(1.0_wp + 1.0e-9_wp)) cycle
      end if
      worst = max(worst, r/res%rhat(i, i))
      text = trim(text)//merge(', ', '  ', len_trim(text) > 0)//'r('//itoa(i)//')'
    end do
    if (len_trim(text) == 0) return
    text = 'outputs '//trim(adjustl(text))//' look noise-free (r/B <= '// &
           trim(adjustl(es_text(worst, 8, 1)))// &
           '): exact ML has no maximum'
  end function noise_free_names

  !> The innovations criterion's outputs whose R is within two standard
  !> errors of zero, 2 sqrt(2/N) of their mean squared innovation S (the
  !> sampling error of S itself): they look noise-free, and res%note says so.
  subroutine noise_free_note(pm, nt, res)
    type(param_map_t), intent(in) :: pm
    integer, intent(in) :: nt
    type(fit_result_t), intent(inout) :: res
    character(len=len(res%note)) :: names
    integer :: i
    names = ''
    do i = 1, size(res%rhat, 1)
      if (res%theta(pm%l%or + i) < 2.0_wp*sqrt(2.0_wp/nt)*res%rhat(i, i)) &
        names = trim(names)//merge(', ', '  ', len_trim(names) > 0)//'r('//itoa(i)//')'
    end do
    if (len_trim(names) > 0) res%note = 'warning: '//trim(adjustl(names))//' within sampling '// &
      'error of zero (below 2 sqrt(2/N) of the mean squared innovation): those outputs look '// &
      'noise-free'
  end subroutine noise_free_note

  !> Check and gather the a priori values and weight and the bounds of the
  !> free parameters; messages name the free parameter by its number.
  subroutine fit_extras(pm, opt, theta0, use_prior, prior, pweight, use_bounds, lower, upper, ex, &
                        bad, status, msg)
    type(param_map_t), intent(in) :: pm
    type(options_t), intent(in) :: opt
    real(c_double), intent(in) :: theta0(:), prior(:), pweight(:, :), lower(:), upper(:)
    integer(c_int), intent(in) :: use_prior, use_bounds
    type(extras_t), intent(out) :: ex
    integer, intent(out) :: bad, status
    character(len=*), intent(out) :: msg
    real(wp) :: ev(pm%nf), v(pm%nf, pm%nf)
    character(len=64) :: what
    integer :: k, ierr

    status = MLID_ERR_INPUT
    bad = 0
    if (pm%nf == 0) then
      msg = 'every parameter is fixed: there is nothing to estimate'
      return
    end if
    if (max(opt%rank_min, opt%rank_max) > pm%nf) then
      write (msg, '(a,i0,a,i0,a)') 'rank_min/rank_max = ', max(opt%rank_min, opt%rank_max), &
        ' is larger than the ', pm%nf, ' free parameters'
      return
    end if
    if (use_prior == 1) then
      if (.not. all(ieee_is_finite(pweight)) .or. .not. all(ieee_is_finite(prior))) then
        msg = 'a priori values and weights must be finite'
        return
      end if
      call sym_eig(0.5_wp*(pweight + transpose(pweight)), ev, v, ierr)
      if (ierr /= 0 .or. maxval(abs(pweight - transpose(pweight))) > 0.0_wp .or. &
          minval(ev) < -1.0e-12_wp*max(1.0_wp, maxval(abs(ev)))) then
        msg = 'the a priori weight matrix must be symmetric positive semi-definite'
        return
      end if
      ex%prior = prior(pm%ifree)
      ex%weight = pweight
    end if
    if (use_bounds == 1) then
      do k = 1, pm%nf
        bad = k
        call bounds_check(lower(pm%ifree(k)), upper(pm%ifree(k)), what)
        if (len_trim(what) > 0) then
          write (msg, '(a,i0,a)') 'free parameter ', k, ': '//trim(what)
          return
        end if
        if (theta0(pm%ifree(k)) < lower(pm%ifree(k)) .or. theta0(pm%ifree(k)) > upper(pm%ifree(k))) then
          write (msg, '(a,i0,a)') 'free parameter ', k, ': start value outside its bounds'
          return
        end if
      end do
      ex%lower = lower(pm%ifree)
      ex%upper = upper(pm%ifree)
    end if
    bad = 0
    status = MLID_OK
    msg = ''
  end subroutine fit_extras

  !> What is wrong with the bounds lower, upper of one parameter ('' when
  !> nothing).  A bound is a number; -Inf below and +Inf above bound nothing.
  subroutine bounds_check(lower, upper, msg)
    real(wp), intent(in) :: lower, upper
    character(len=*), intent(out) :: msg
    msg = ''
    if (ieee_is_nan(lower)) then
      msg = 'lower bound is not a number'
    else if (ieee_is_nan(upper)) then
      msg = 'upper bound is not a number'
    else if (lower > huge(lower)) then
      msg = 'lower bound is +Inf (no value lies above it)'
    else if (upper < -huge(upper)) then
      msg = 'upper bound is -Inf (no value lies below it)'
    else if (lower > upper) then
      msg = 'lower bound above upper bound'
    end if
  end subroutine bounds_check

  !> The view of fit res (map pm, options opt) from start theta0, for ny
  !> outputs over nt samples; bad: the checks' free parameter (fit_solve).
  function fit_view(res, pm, opt, theta0, ny, nt, bad) result(v)
    type(fit_result_t), intent(in) :: res
    type(param_map_t), intent(in) :: pm
    type(options_t), intent(in) :: opt
    real(wp), intent(in) :: theta0(:)
    integer, intent(in) :: ny, nt, bad
    type(fit_view_t) :: v
    integer :: nf, k

    nf = pm%nf
    v%theta_start = theta0
    v%theta = theta0
    allocate (v%sigma(size(theta0)), v%sigma_c(size(theta0)), v%cov(nf, nf), v%cov_c(nf, nf), &
              v%info(nf, nf), v%grad(nf), v%eigval(nf), v%eigvec(nf, nf), v%rhat(ny, ny), &
              v%yhat(ny, nt), v%rnoise(ny), v%hist(opt%max_iter + 1))
    v%sigma = 0.0_wp
    v%sigma_c = 0.0_wp
    v%cov = 0.0_wp
    v%cov_c = 0.0_wp
    v%info = 0.0_wp
    v%grad = 0.0_wp
    v%eigval = 0.0_wp
    v%eigvec = 0.0_wp
    v%rhat = 0.0_wp
    v%yhat = 0.0_wp
    v%hist = 0.0_wp
    v%rnoise = ieee_value(1.0_wp, ieee_quiet_nan)
    allocate (v%kc(0))
    if (allocated(res%kc)) v%kc = res%kc
    v%bad = bad
    if (allocated(res%theta_start)) v%theta_start = res%theta_start
    if (.not. allocated(res%theta)) return
    v%theta = res%theta
    if (opt%noise_criterion >= 1) v%rnoise = v%theta(pm%l%or + 1:pm%l%or + ny)
    v%hist = res%cost_hist
    if (.not. allocated(res%info)) return
    do k = 1, nf
      v%sigma(pm%ifree(k)) = sqrt(max(0.0_wp, res%cov(k, k)))
    end do
    v%cov = res%cov
    if (allocated(res%cov_c)) then
      v%cov_c = res%cov_c
      do k = 1, nf
        v%sigma_c(pm%ifree(k)) = sqrt(max(0.0_wp, res%cov_c(k, k)))
      end do
      v%lag = res%lag
    end if
    v%info = res%info
    v%grad = res%grad
    v%eigval = res%eigval
    v%eigvec = res%eigvec
    v%rhat = res%rhat
    ! the frequency-domain methods' outputs are transforms, not the record's
    if (.not. frequency_method(opt)) v%yhat = res%yhat
    v%cost = res%cost
    v%niter = res%niter
    v%reason = res%reason
    v%converged = res%converged
    v%rank = res%rank
    v%bad = res%bad_param
  end function fit_view

end module mlid_fit_driver
