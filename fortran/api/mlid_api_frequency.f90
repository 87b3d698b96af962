!> The flat interface's frequency domain: Fourier transforms, the
!> frequency-domain fit's data, the recursive estimator, measured and
!> model frequency responses, transfer-function fits.  The routines that
!> take a record, a model or more than a few values take the handle alone:
!> the problem's parts (mlid_api_problem) and the values given by name
!> (mlid_api_values), and keep what they give in the handle's results by
!> name.  The Fourier transform, the sample step and a transfer function's
!> response keep their few arguments: cheap calls, which values by name
!> would make several times slower.  Conventions: mlid_api_deck's comment.
module mlid_api_frequency
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t
  use mlid_model_factory, only: model_create
  use mlid_options, only: options_t, options_from_flat, options_to_flat, frequency_method, NOPT, &
                          METHOD_FREQ_EE
  use mlid_params, only: param_map_t, apply_ties
  use mlid_setup, only: problem_setup
  use mlid_sampling, only: record_common_step
  use mlid_fourier, only: fourier_transform
  use mlid_smooth, only: smooth_fourier, smooth_uniform_check
  use mlid_local_smooth, only: smooth_local, deriv_local, LOCAL_NO_CUTOFF
  use mlid_text, only: itoa
  use mlid_frequency, only: freq_record, freq_likelihood, freq_grid
  use mlid_recursive_fd, only: recursive_fdee
  use mlid_freq_response, only: welch_spectra, response_from_spectra, model_response, &
                                response_bands, unwrap_deg, DB, DEG
  use mlid_transfer_fit, only: tf_size, tf_start, tf_fit, tf_residuals, tf_log_response, &
                               coherence_weight
  use mlid_handles, only: session_t, handle_session, call_session
  use mlid_named, only: named_t
  use mlid_problem, only: problem_needs, PART_MODEL, PART_PARAMS, PART_RECORD
  implicit none
  private
  public :: mlid_fourier_transform, mlid_uniform_step, mlid_recursive_fdee, mlid_freq_evaluate, &
            mlid_freq_response, mlid_model_freq_response, mlid_tf_fit, mlid_tf_residuals, &
            mlid_tf_response, mlid_smooth_channel

contains

  !> The finite Fourier transform (mlid_fourier) of the channels x(nch, n)
  !> sampled at t0, t0 + dt, ... at the frequencies w(nw) (rad/s): the
  !> integral of their piecewise-linear interpolant times exp(-i w t),
  !> real and imaginary parts (nch, nw).
  subroutine mlid_fourier_transform(nch, n, x, dt, t0, nw, w, xre, xim, status, msg)
    integer(c_int), intent(in) :: nch, n, nw
    real(c_double), intent(in) :: x(nch, n), dt, t0, w(nw)
    real(c_double), intent(out) :: xre(nch, nw), xim(nch, nw)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    complex(wp) :: xf(nch, nw)
    xre = 0.0_wp
    xim = 0.0_wp
    status = MLID_ERR_INPUT
    if (n < 2) then
      msg = 'a record to transform needs at least two samples'
    else if (.not. (dt > 0.0_wp .and. ieee_is_finite(dt) .and. ieee_is_finite(t0))) then
      msg = 'the sample interval must be positive and finite'
    else if (.not. (all(ieee_is_finite(x)) .and. all(ieee_is_finite(w)))) then
      msg = 'samples and frequencies must be finite'
    else
      call fourier_transform(x, dt, t0, w, xf)
      xre = real(xf, wp)
      xim = aimag(xf)
      status = MLID_OK
      msg = ''
    end if
  end subroutine mlid_fourier_transform

  !> The global Fourier smoother (mlid_smooth; local = 0) or the local one
  !> (mlid_local_smooth; local = 1) of one channel x(n) at the times t(n)
  !> (uniform): smoothed xs, derivative xd, cut-off fc [Hz] (Fourier: the
  !> rule's, or fc_given's when > 0; local: 0).
  subroutine mlid_smooth_channel(n, t, x, fc_given, local, xs, xd, fc, status, msg)
    integer(c_int), intent(in) :: n, local
    real(c_double), intent(in) :: t(n), x(n), fc_given
    real(c_double), intent(out) :: xs(n), xd(n), fc
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    real(wp) :: dt
    integer :: at, kc
    character(len=256) :: why
    xs = 0.0_wp
    xd = 0.0_wp
    fc = 0.0_wp
    status = MLID_ERR_INPUT
    if (.not. (all(ieee_is_finite(x)) .and. all(ieee_is_finite(t)))) then
      msg = 'times and samples must be finite'
      return
    end if
    call smooth_uniform_check(t, dt, at, why)
    if (at > 0) then
      msg = 'sample '//itoa(at)//': '//trim(why)
      return
    end if
    if (.not. (fc_given >= 0.0_wp .and. ieee_is_finite(fc_given))) then
      msg = 'the cut-off must be a frequency > 0 in Hz'
      return
    end if
    if (local == 0) then
      call smooth_fourier(x, dt, xs, xd, kc, fc, status, msg, fc_given)
    else if (fc_given > 0.0_wp) then
      status = MLID_ERR_INPUT
      msg = LOCAL_NO_CUTOFF
    else
      call deriv_local(x, dt, xd, status, msg)
      if (status == MLID_OK) call smooth_local(x, xs, status, msg)
    end if
  end subroutine mlid_smooth_channel

  !> The one sample step dt of a record whose nseg manoeuvres start at
  !> samples segstart: each uniformly sampled and all at one step
  !> (mlid_record's record_common_step, the check of every frequency-domain
  !> tool), else the message why not.
  subroutine mlid_uniform_step(nt, t, nseg, segstart, dt, status, msg)
    integer(c_int), intent(in) :: nt, nseg, segstart(nseg)
    real(c_double), intent(in) :: t(nt)
    real(c_double), intent(out) :: dt
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call record_common_step(t, segstart, dt, status, msg)
  end subroutine mlid_uniform_step

  !> The band of the frequency-domain methods (rad/s), checked as their
  !> options are (mlid_options' band_check): n_freq frequencies from f_min
  !> to f_max Hz (mlid_frequency's freq_grid).
  subroutine band_omega(n_freq, f_min, f_max, w, status, msg)
    integer(c_int), intent(in) :: n_freq
    real(c_double), intent(in) :: f_min, f_max
    real(wp), allocatable, intent(out) :: w(:)
    integer(c_int), intent(out) :: status
    character(len=*), intent(out) :: msg
    type(options_t) :: opt
    integer :: iopt(NOPT)
    real(wp) :: ropt(NOPT)
    opt%method = METHOD_FREQ_EE
    opt%n_freq = n_freq
    opt%f_min = f_min
    opt%f_max = f_max
    call options_to_flat(opt, iopt, ropt)
    call options_from_flat(iopt, ropt, opt, status, msg)
    if (status == MLID_OK) then
      w = 8.0_wp*atan(1.0_wp)*freq_grid(opt)
    else
      allocate (w(0))
    end if
  end subroutine band_omega

  !> Recursive frequency-domain equation error (mlid_recursive_fd) over a
  !> moving window, on the record of handle h (mlid_api_problem: one
  !> manoeuvre, its outputs the measured states x) with its given values
  !> (mlid_api_values): f0 (nx, nx) and g0 (nx, nu) with their free entries
  !> marked in free_f and free_g (1 free), the band n_freq, f_min, f_max (Hz;
  !> the frequency-domain methods' band, checked as theirs), window (samples
  !> in a window) and stride (samples between the ends of two windows).
  !> Results: t_end (nwin) each window's last time, estimates and sigma
  !> (np, nwin) the free entries (F column by column, then G) per window.
  subroutine mlid_recursive_fdee(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    real(wp), allocatable :: f0(:, :), g0(:, :), w(:), tend(:), est(:, :), sig(:, :)
    integer, allocatable :: free_f(:, :), free_g(:, :)
    real(wp) :: f_min, f_max
    integer :: n_freq, window, stride, nx, nu, nt, np, nwin

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call problem_needs(s%problem, [PART_RECORD], status, msg)
    if (status /= MLID_OK) return
    associate (p => s%problem, g => s%given)
      nx = size(p%y, 1)
      nu = size(p%u, 1)
      nt = size(p%t)
      call g%get('f0', f0, status, msg, [nx, nx])
      call g%get('g0', g0, status, msg, [nx, nu])
      call g%get('free_f', free_f, status, msg, [nx, nx])
      call g%get('free_g', free_g, status, msg, [nx, nu])
      call g%get('n_freq', n_freq, status, msg)
      call g%get('f_min', f_min, status, msg)
      call g%get('f_max', f_max, status, msg)
      call g%get('window', window, status, msg)
      call g%get('stride', stride, status, msg)
      if (status /= MLID_OK) return
      call band_omega(n_freq, f_min, f_max, w, status, msg)
      if (status /= MLID_OK) return
      np = count(free_f == 1) + count(free_g == 1)
      status = MLID_ERR_INPUT
      if (np == 0) then
        msg = 'np must count the free entries of F and G (at least one)'
        return
      else if (.not. (all(ieee_is_finite(p%t)) .and. all(ieee_is_finite(p%y)) .and. &
                      all(ieee_is_finite(p%u)))) then
        msg = 'time, states and inputs must be finite'
        return
      end if
      ! one window where window or stride is bad: recursive_fdee refuses them first
      nwin = 1
      if (window >= 3 .and. window <= nt .and. stride >= 1) nwin = (nt - window)/stride + 1
      allocate (tend(nwin), est(np, nwin), sig(np, nwin))
      call recursive_fdee(p%t, p%y, p%u, f0, g0, free_f == 1, free_g == 1, w, window, stride, &
                          tend, est, sig, status, msg)
    end associate
    if (status /= MLID_OK) return
    call s%results%put('t_end', tend)
    call s%results%put('estimates', est)
    call s%results%put('sigma', sig)
  end subroutine mlid_recursive_fdee

  !> The frequency-domain methods' data and fit (mlid_frequency) at the
  !> parameters of handle h's problem (mlid_api_problem: model, params,
  !> record, options).  Results: frequencies (nk: Hz, manoeuvre after
  !> manoeuvre, n_freq each), the measured left-hand sides z_re, z_im
  !> (output error: the outputs' transforms Y; equation error: i w Y for the
  !> outputs that measure a state) and the model's zhat_re, zhat_im (ny,
  !> nk); the cost, its gradient and information over the free parameters,
  !> S-hat (rhat) there, and transient_terms (those estimated).
  subroutine mlid_freq_evaluate(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    real(wp), allocatable :: th(:), tf(:), uf(:, :), yf(:, :), yh(:, :), grad(:), info(:, :), &
                             rhat(:, :)
    real(wp) :: cost
    integer :: nf, nseg, nterms

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    associate (p => s%problem)
      call problem_setup(p, m, opt, pm, status, msg)
      if (status /= MLID_OK) return
      nf = pm%nf
      if (.not. frequency_method(opt)) then
        status = MLID_ERR_INPUT
        msg = 'frequency residuals are for method = ''frequency_output_error'' or '// &
              '''frequency_equation_error'''
        return
      end if
      th = p%theta
      call apply_ties(pm%tie, th)
      call freq_record(m, th, pm, p%t, p%u, p%y, opt, tf, uf, yf, status, msg)
      if (status /= MLID_OK) return
      nseg = size(p%segstart)
      allocate (grad(nf), info(nf, nf), rhat(p%ny, p%ny), yh(p%ny, 2*opt%n_freq*nseg))
      call freq_likelihood(m, th, pm, tf, uf, yf, opt, cost, rhat, yh, status, msg, grad, info, &
                           nterms=nterms)
    end associate
    if (status /= MLID_OK) return
    call s%results%put('frequencies', reshape(spread(freq_grid(opt), 2, nseg), [opt%n_freq*nseg]))
    call s%results%put('z_re', yf(:, 1::2))
    call s%results%put('z_im', yf(:, 2::2))
    call s%results%put('zhat_re', yh(:, 1::2))
    call s%results%put('zhat_im', yh(:, 2::2))
    call s%results%put('cost', cost)
    call s%results%put('gradient', grad)
    call s%results%put('information', info)
    call s%results%put('rhat', rhat)
    call s%results%put('transient_terms', nterms)
  end subroutine mlid_freq_evaluate

  !> The frequency response y/u of a record (mlid_freq_response) from
  !> handle h's given values: the channels u and y, the sample step dt, the
  !> first sample of each manoeuvre segstart, segments of lseg samples
  !> overlapping by nover within each manoeuvre.  Results: frequency (Hz:
  !> those of the transform's length fft_length(lseg) but 0 Hz), response_re
  !> and response_im (H), coherence, input_spectrum and output_spectrum,
  !> gain (dB), phase (deg, unwrapped), their random errors sigma_gain and
  !> sigma_phase (1 sigma), and averages (the segments averaged).
  subroutine mlid_freq_response(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    real(wp), allocatable :: u(:), y(:), ff(:), uu(:), yy(:), coh(:), gain(:), phase(:), &
                             sgain(:), sphase(:)
    complex(wp), allocatable :: uy(:), hh(:)
    integer, allocatable :: segstart(:)
    real(wp) :: dt
    integer :: lseg, nover, nd, nfreq

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    associate (g => s%given)
      call g%get('u', u, status, msg)
      call g%get('y', y, status, msg, [size(u)])
      call g%get('dt', dt, status, msg)
      call g%get('segstart', segstart, status, msg)
      call g%get('lseg', lseg, status, msg)
      call g%get('nover', nover, status, msg)
    end associate
    if (status /= MLID_OK) return
    if (.not. (all(ieee_is_finite(u)) .and. all(ieee_is_finite(y)))) then
      status = MLID_ERR_INPUT
      msg = 'frequency response: the input or output channel has a value that is not finite'
      return
    end if
    call welch_spectra(u, y, dt, lseg, nover, segstart, ff, uu, yy, uy, nd, status, msg)
    if (status /= MLID_OK) return
    nfreq = size(ff)
    allocate (hh(nfreq), coh(nfreq), gain(nfreq), phase(nfreq), sgain(nfreq), sphase(nfreq))
    call response_from_spectra(uu, yy, uy, nd, hh, coh, gain, phase, sgain, sphase)
    call s%results%put('frequency', ff)
    call s%results%put('response_re', real(hh, wp))
    call s%results%put('response_im', aimag(hh))
    call s%results%put('coherence', coh)
    call s%results%put('input_spectrum', uu)
    call s%results%put('output_spectrum', yy)
    call s%results%put('gain', gain)
    call s%results%put('phase', phase)
    call s%results%put('sigma_gain', sgain)
    call s%results%put('sigma_phase', sphase)
    call s%results%put('averages', nd)
  end subroutine mlid_freq_response

  !> The frequency response of output `output` to input `input` (1-based)
  !> of the linear model of handle h at its parameters (mlid_api_problem:
  !> model, params), from the given values w (nfreq, rad/s), jac (nth, nq:
  !> dtheta/dq) and cov (nq, nq: the covariance of q) (mlid_freq_response).
  !> Results: response_re and response_im (T), gain (dB), phase (deg,
  !> unwrapped) and their sigmas sigma_gain, sigma_phase by the delta method
  !> (nfreq), and the derivatives dT/dq derivatives_re, derivatives_im
  !> (nfreq, nq).
  subroutine mlid_model_freq_response(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    class(model_t), allocatable :: m
    real(wp), allocatable :: w(:), jac(:, :), cov(:, :)
    real(wp), allocatable, dimension(:, :, :) :: gain, phase, sgain, sphase
    complex(wp), allocatable :: t(:, :, :), dt(:, :, :, :)
    integer :: i, j, nq

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    associate (p => s%problem, g => s%given)
      call problem_needs(p, [PART_MODEL, PART_PARAMS], status, msg)
      if (status /= MLID_OK) return
      call g%get('jac', jac, status, msg)
      nq = size(jac, 2)
      call g%get('cov', cov, status, msg, [nq, nq])
      call g%get('w', w, status, msg)
      call g%get('input', i, status, msg)
      call g%get('output', j, status, msg)
      if (status /= MLID_OK) return
      if (i < 1 .or. i > p%nu .or. j < 1 .or. j > p%ny) then
        status = MLID_ERR_INPUT
        write (msg, '(a,i0,a,i0,a,i0,a,i0)') 'model frequency response: input ', i, &
          ' and output ', j, ' must be at most ', p%nu, ' and ', p%ny
        return
      end if
      call model_create(p%mkind, p%nx, p%nu, p%ny, p%nw, p%iconst, p%rconst, m, status, msg)
      if (status /= MLID_OK) return
      allocate (t(p%ny, p%nu, size(w)), dt(p%ny, p%nu, size(w), nq))
      call model_response(m, p%theta, w, jac, t, dt, status, msg)
      if (status /= MLID_OK) return
    end associate
    allocate (gain, phase, sgain, sphase, mold=real(t, wp))   ! (ny, nu, nfreq) as t
    call response_bands(t, dt, cov, gain, phase, sgain, sphase)
    call s%results%put('response_re', real(t(j, i, :), wp))
    call s%results%put('response_im', aimag(t(j, i, :)))
    call s%results%put('gain', gain(j, i, :))
    call s%results%put('phase', phase(j, i, :))
    call s%results%put('sigma_gain', sgain(j, i, :))
    call s%results%put('sigma_phase', sphase(j, i, :))
    call s%results%put('derivatives_re', real(dt(j, i, :, :), wp))
    call s%results%put('derivatives_im', aimag(dt(j, i, :, :)))
  end subroutine mlid_model_freq_response

  !> Weights of the transfer-function mismatch: 1, or by coherence.
  pure function tf_weights(coh, use_coh) result(wt)
    real(wp), intent(in) :: coh(:)
    integer, intent(in) :: use_coh
    real(wp) :: wt(size(coh))
    wt = 1.0_wp
    if (use_coh /= 0) wt = coherence_weight(coh)
  end function tf_weights

  !> The given values every transfer-function call takes: the frequencies w
  !> (rad/s), the orders m, n and delay (1: with a delay).
  subroutine tf_given(g, w, m, n, delay, status, msg)
    type(named_t), intent(in) :: g
    real(wp), allocatable, intent(out) :: w(:)
    integer, intent(out) :: m, n, delay
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    m = 0
    n = 0
    delay = 0
    call g%get('w', w, status, msg)
    call g%get('m', m, status, msg)
    call g%get('n', n, status, msg)
    call g%get('delay', delay, status, msg)
  end subroutine tf_given

  !> The given values of the response a transfer function is fitted to:
  !> gain (dB) and phase (deg) at the nfreq frequencies, and the weights
  !> of the mismatch (by the coherence coh when use_coh = 1, else 1).
  subroutine tf_measured(g, nfreq, gain, phase, wt, status, msg)
    type(named_t), intent(in) :: g
    integer, intent(in) :: nfreq
    real(wp), allocatable, intent(out) :: gain(:), phase(:), wt(:)
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    real(wp), allocatable :: coh(:)
    integer :: use_coh
    use_coh = 0
    call g%get('gain', gain, status, msg, [nfreq])
    call g%get('phase', phase, status, msg, [nfreq])
    call g%get('coh', coh, status, msg, [nfreq])
    call g%get('use_coh', use_coh, status, msg)
    if (status == MLID_OK) then
      wt = tf_weights(coh, use_coh)
    else
      allocate (wt(0))
    end if
  end subroutine tf_measured

  !> Fit T(s) = N(s)/D(s) e^(-tau s) (orders m, n; delay when delay = 1)
  !> to gain (dB) and phase (deg) at w (rad/s) by the handling-qualities
  !> mismatch (mlid_transfer_fit), weighted by coherence when use_coh = 1;
  !> from x0 when use_start = 1, else from Levy's least squares with the
  !> delay at tau0; at most max_iter iterations.  Parameters with isfree = 0
  !> keep their value in x0.  All of these are handle h's given values
  !> (with coh).  Results: start (the start used), estimate, both [b_0..b_m,
  !> a_0..a_(n-1), tau], covariance, mismatch and iterations.
  subroutine mlid_tf_fit(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    real(wp), allocatable :: w(:), gain(:), phase(:), wt(:), x0(:), x(:), cov(:, :)
    integer, allocatable :: isfree(:)
    real(wp) :: tau0, cost
    integer :: m, n, delay, use_start, max_iter, niter

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    associate (g => s%given)
      call tf_given(g, w, m, n, delay, status, msg)
      call tf_measured(g, size(w), gain, phase, wt, status, msg)
      call g%get('tau0', tau0, status, msg)
      call g%get('use_start', use_start, status, msg)
      call g%get('max_iter', max_iter, status, msg)
      call g%get('x0', x0, status, msg)
      if (status /= MLID_OK) return
      call g%get('isfree', isfree, status, msg, [size(x0)])
    end associate
    if (status /= MLID_OK) return
    call tf_check(w, gain, phase, m, n, delay, size(x0), status, msg)
    if (status /= MLID_OK) return
    x = x0                                  ! the start, or the fixed ones' values
    if (use_start == 0) then
      call tf_start(m, n, delay /= 0, tau0, w, gain, phase, wt, isfree /= 0, x, status, msg)
      if (status /= MLID_OK) return
    end if
    call s%results%put('start', x)
    allocate (cov(size(x), size(x)))
    call tf_fit(m, n, delay /= 0, w, gain, phase, wt, isfree /= 0, max_iter, x, cost, cov, niter, &
                status, msg)
    call s%results%put('estimate', x)
    call s%results%put('covariance', cov)
    call s%results%put('mismatch', cost)
    call s%results%put('iterations', niter)
  end subroutine mlid_tf_fit

  !> Orders, sizes and frequencies of a transfer-function fit.
  subroutine tf_check(w, gain, phase, m, n, delay, np, status, msg)
    real(wp), intent(in) :: w(:), gain(:), phase(:)
    integer, intent(in) :: m, n, delay, np
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call tf_orders(m, n, delay, np, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (2*size(w) < np + 1) then
      write (msg, '(a,i0,a,i0,a)') 'transfer-function fit: ', size(w), &
        ' frequencies are too few for ', np, ' parameters'
    else if (.not. (all(ieee_is_finite(w)) .and. all(ieee_is_finite(gain)) .and. &
                    all(ieee_is_finite(phase)))) then
      msg = 'transfer-function fit: a frequency, gain or phase is not finite'
    else if (any(w <= 0.0_wp)) then
      msg = 'transfer-function fit: frequencies must be positive'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine tf_check

  !> The mismatch's residuals (2 nfreq, r'r = the mismatch) and their
  !> Jacobian (2 nfreq, np) at the given x, from handle h's given values
  !> as mlid_tf_fit takes them (w, gain, phase, coh, use_coh, m, n, delay).
  !> Results: residuals and jacobian.
  subroutine mlid_tf_residuals(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    real(wp), allocatable :: w(:), gain(:), phase(:), wt(:), x(:), r(:), jr(:, :)
    integer :: m, n, delay

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    associate (g => s%given)
      call tf_given(g, w, m, n, delay, status, msg)
      call tf_measured(g, size(w), gain, phase, wt, status, msg)
      call g%get('x', x, status, msg)
    end associate
    if (status /= MLID_OK) return
    call tf_orders(m, n, delay, size(x), status, msg)
    if (status /= MLID_OK) return
    allocate (r(2*size(w)), jr(2*size(w), size(x)))
    call tf_residuals(m, n, delay /= 0, x, w, gain, phase, wt, r, jr)
    call s%results%put('residuals', r)
    call s%results%put('jacobian', jr)
  end subroutine mlid_tf_residuals

  !> Orders m >= 0, n >= 1 and np = tf_size, the length of x: the
  !> parameters b_0..b_m, a_0..a_(n-1) and tau when delay = 1.
  subroutine tf_orders(m, n, delay, np, status, msg)
    integer, intent(in) :: m, n, delay, np
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    status = MLID_OK
    msg = ''
    if (m < 0 .or. n < 1) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0,a)') 'transfer function: orders m = ', m, ', n = ', n, &
        ' must be m >= 0, n >= 1'
    else if (np /= tf_size(m, n, delay /= 0)) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0,a,i0,a,i0,a,i0)') 'transfer function: orders m = ', m, ', n = ', &
        n, ' (delay ', delay, ') take ', tf_size(m, n, delay /= 0), ' parameters, got ', np
    end if
  end subroutine tf_orders

  !> Gain (dB) and phase (deg, unwrapped) of a fitted transfer function at w.
  subroutine mlid_tf_response(nfreq, w, m, n, delay, np, x, gain, phase, status, msg)
    integer(c_int), intent(in) :: nfreq, m, n, delay, np
    real(c_double), intent(in) :: w(nfreq), x(np)
    real(c_double), intent(out) :: gain(nfreq), phase(nfreq)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    complex(wp) :: lt, dlt(np)
    integer :: k
    gain = 0.0_wp
    phase = 0.0_wp
    call tf_orders(m, n, delay, np, status, msg)
    if (status /= MLID_OK) return
    do k = 1, nfreq
      call tf_log_response(m, n, delay /= 0, x, w(k), lt, dlt)
      gain(k) = DB*real(lt)
      phase(k) = DEG*aimag(lt)
    end do
    call unwrap_deg(phase)
  end subroutine mlid_tf_response

end module mlid_api_frequency
