!> The flat interface's frequency domain: Fourier transforms, the
!> frequency-domain fit's data, the recursive estimator, measured and
!> model frequency responses, transfer-function fits.
!> Conventions: mlid_api_deck's comment.
module mlid_api_frequency
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan, ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t
  use mlid_model_factory, only: model_create
  use mlid_options, only: options_t, options_from_flat, options_to_flat, frequency_method, NOPT, &
                          METHOD_FREQ_EE
  use mlid_params, only: param_map_t, apply_ties, ties_of
  use mlid_setup, only: setup
  use mlid_sampling, only: record_common_step
  use mlid_fourier, only: fourier_transform
  use mlid_frequency, only: freq_record, freq_likelihood, freq_grid
  use mlid_recursive_fd, only: recursive_fdee
  use mlid_fft, only: fft_length
  use mlid_freq_response, only: welch_spectra, response_from_spectra, model_response, &
                                response_bands, unwrap_deg, DB, DEG
  use mlid_transfer_fit, only: tf_size, tf_start, tf_fit, tf_residuals, tf_log_response, &
                               coherence_weight
  implicit none
  private
  public :: mlid_fourier_transform, mlid_uniform_step, mlid_recursive_fdee, mlid_freq_evaluate, &
            mlid_freq_count, mlid_freq_response, mlid_model_freq_response, mlid_tf_fit, &
            mlid_tf_residuals, mlid_tf_response

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
  !> moving window of `window` samples, one fit every `stride`: the measured
  !> states x(nx, nt), inputs u(nu, nt), F0 and G0 with the free entries
  !> marked (freef, freeg: 1 free), the band n_freq, f_min, f_max (Hz; the
  !> frequency-domain methods' band, checked as theirs); est and sig
  !> (np, nwin) the free entries (F column by column, then G) per window,
  !> tend(nwin) each window's last time.
  subroutine mlid_recursive_fdee(nx, nu, nt, t, x, u, f0, g0, freef, freeg, n_freq, f_min, f_max, &
                                 window, stride, nwin, np, tend, est, sig, status, msg)
    integer(c_int), intent(in) :: nx, nu, nt, n_freq, window, stride, nwin, np
    real(c_double), intent(in) :: t(nt), x(nx, nt), u(nu, nt), f0(nx, nx), g0(nx, nu), f_min, f_max
    integer(c_int), intent(in) :: freef(nx, nx), freeg(nx, nu)
    real(c_double), intent(out) :: tend(nwin), est(np, nwin), sig(np, nwin)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    real(wp), allocatable :: w(:)
    tend = 0.0_wp
    est = 0.0_wp
    sig = 0.0_wp
    call band_omega(n_freq, f_min, f_max, w, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (np /= count(freef == 1) + count(freeg == 1) .or. np == 0) then
      msg = 'np must count the free entries of F and G (at least one)'
    else if (.not. (all(ieee_is_finite(t)) .and. all(ieee_is_finite(x)) .and. &
                    all(ieee_is_finite(u)))) then
      msg = 'time, states and inputs must be finite'
    else
      call recursive_fdee(t, x, u, f0, g0, freef == 1, freeg == 1, w, window, stride, tend, est, &
                          sig, status, msg)
    end if
  end subroutine mlid_recursive_fdee

  !> The frequency-domain methods' data and fit at theta (mlid_frequency):
  !> freq(nk) the frequencies (Hz, manoeuvre after manoeuvre, nk = n_freq
  !> times the manoeuvres), z the measured left-hand sides (output error:
  !> the outputs' transforms Y; equation error: i w Y for the outputs that
  !> measure a state), zhat the model's, real and imaginary parts (ny, nk);
  !> the cost, its gradient and information over the nf free parameters and
  !> S-hat (rhat) there.
  subroutine mlid_freq_evaluate(mkind, nx, nu, ny, nw, nth, theta, isfree, ntie, mtie, tie_to, &
                                 tie_from, tie_scale, tie_offset, nic, iconst, nrc, rconst, nt, &
                                 t, u, y, nseg, segstart, iopt, ropt, nk, freq, zre, zim, &
                                 zhre, zhim, nf, cost, grad, info, rhat, nterms, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nth, nic, nrc, nt, nseg, nk, nf
    integer(c_int), intent(in) :: segstart(nseg)
    real(c_double), intent(in) :: theta(nth)
    integer(c_int), intent(in) :: isfree(nth), ntie, mtie, tie_to(mtie), tie_from(mtie)
    real(c_double), intent(in) :: tie_scale(mtie), tie_offset(nth)
    integer(c_int), intent(in) :: iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    real(c_double), intent(in) :: t(nt), u(nu, nt), y(ny, nt)
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16)
    real(c_double), intent(out) :: freq(nk), zre(ny, nk), zim(ny, nk), zhre(ny, nk), zhim(ny, nk)
    real(c_double), intent(out) :: cost, grad(nf), info(nf, nf), rhat(ny, ny)
    integer(c_int), intent(out) :: nterms      !< the transient terms estimated (mlid_frequency)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    real(wp), allocatable :: tf(:), uf(:, :), yf(:, :), yh(:, :)
    real(wp) :: th(nth)
    integer :: k

    freq = 0.0_wp
    nterms = 0
    cost = 0.0_wp
    grad = 0.0_wp
    info = 0.0_wp
    rhat = 0.0_wp
    zre = 0.0_wp
    zim = 0.0_wp
    zhre = 0.0_wp
    zhim = 0.0_wp
    call setup(mkind, nx, nu, ny, nw, theta, isfree, &
               ties_of(ntie, tie_to, tie_from, tie_scale, tie_offset), iconst, rconst, t, u, y, iopt, &
               ropt, nf, m, opt, pm, status, msg, segstart)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (.not. frequency_method(opt)) then
      msg = 'frequency residuals are for method = ''frequency_output_error'' or '// &
            '''frequency_equation_error'''
      return
    else if (nk /= opt%n_freq*nseg) then
      write (msg, '(a,i0,a,i0)') 'nk = ', nk, ' must be n_freq times the manoeuvres = ', &
        opt%n_freq*nseg
      return
    end if
    th = theta
    call apply_ties(pm%tie, th)
    call freq_record(m, th, pm, t, u, y, opt, tf, uf, yf, status, msg)
    if (status /= MLID_OK) return
    if (nf /= pm%nf) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0,a)') 'nf = ', nf, ' but ', pm%nf, ' parameters are free'
      return
    end if
    allocate (yh(ny, 2*nk))
    call freq_likelihood(m, th, pm, tf, uf, yf, opt, cost, rhat, yh, status, msg, grad, info, &
                         nterms=k)
    nterms = k
    if (status /= MLID_OK) return
    freq = reshape(spread(freq_grid(opt), 2, nseg), [nk])
    zre = yf(:, 1::2)
    zim = yf(:, 2::2)
    zhre = yh(:, 1::2)
    zhim = yh(:, 2::2)
  end subroutine mlid_freq_evaluate

  !> The number of frequencies of a measured response from segments of lseg
  !> samples (those of the transform's length fft_length(lseg), but 0 Hz).
  subroutine mlid_freq_count(lseg, nfreq)
    integer(c_int), intent(in) :: lseg
    integer(c_int), intent(out) :: nfreq
    nfreq = fft_length(max(lseg, 2))/2
  end subroutine mlid_freq_count

  !> The frequency response y/u of a record (mlid_freq_response): segments
  !> of lseg samples overlapping by nover within each of its nseg manoeuvres
  !> (starting at samples segstart); f (Hz), H, coherence, spectra, gain
  !> (dB), phase (deg, unwrapped), their random errors (1 sigma) and the
  !> number of averages nd.  nfreq from mlid_freq_count.
  subroutine mlid_freq_response(nt, u, y, dt, nseg, segstart, lseg, nover, nfreq, f, h_re, h_im, &
                                coh, guu, gyy, gain, phase, sgain, sphase, nd, status, msg)
    integer(c_int), intent(in) :: nt, lseg, nover, nfreq, nseg, segstart(nseg)
    real(c_double), intent(in) :: u(nt), y(nt), dt
    real(c_double), intent(out), dimension(nfreq) :: f, h_re, h_im, coh, guu, gyy, gain, phase, &
                                                     sgain, sphase
    integer(c_int), intent(out) :: nd, status
    character(len=256), intent(out) :: msg
    real(wp), allocatable :: ff(:), uu(:), yy(:)
    complex(wp), allocatable :: uy(:)
    complex(wp) :: h(nfreq)
    integer :: ndi, st
    f = 0.0_wp
    h_re = 0.0_wp
    h_im = 0.0_wp
    coh = 0.0_wp
    guu = 0.0_wp
    gyy = 0.0_wp
    gain = 0.0_wp
    phase = 0.0_wp
    sgain = 0.0_wp
    sphase = 0.0_wp
    nd = 0
    if (.not. (all(ieee_is_finite(u)) .and. all(ieee_is_finite(y)))) then
      status = MLID_ERR_INPUT
      msg = 'frequency response: the input or output channel has a value that is not finite'
      return
    end if
    call welch_spectra(u, y, dt, lseg, nover, segstart, ff, uu, yy, uy, ndi, st, msg)
    status = st
    if (st /= MLID_OK) return
    if (size(ff) /= nfreq) then
      status = MLID_ERR_INPUT
      msg = 'frequency response: nfreq is not mlid_freq_count(lseg)'
      return
    end if
    call response_from_spectra(uu, yy, uy, ndi, h, coh, gain, phase, sgain, sphase)
    f = ff
    guu = uu
    gyy = yy
    h_re = real(h)
    h_im = aimag(h)
    nd = ndi
  end subroutine mlid_freq_response

  !> The frequency response T (ny, nu, nfreq) of a linear model at w (rad/s)
  !> with its derivatives dT/dq (ny, nu, nfreq, nq) through jac = dtheta/dq,
  !> and gain (dB), phase (deg, unwrapped) and their sigmas from cov(q) by
  !> the delta method (mlid_freq_response).
  subroutine mlid_model_freq_response(mkind, nx, nu, ny, nw, nth, theta, nic, iconst, nrc, rconst, &
                                      nq, jac, cov, nfreq, w, t_re, t_im, dt_re, dt_im, gain, &
                                      phase, sgain, sphase, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nth, nic, nrc, nq, nfreq
    real(c_double), intent(in) :: theta(nth), rconst(nrc), jac(nth, nq), cov(nq, nq), w(nfreq)
    integer(c_int), intent(in) :: iconst(nic)
    real(c_double), intent(out), dimension(ny, nu, nfreq) :: t_re, t_im, gain, phase, sgain, sphase
    real(c_double), intent(out), dimension(ny, nu, nfreq, nq) :: dt_re, dt_im
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    class(model_t), allocatable :: m
    complex(wp) :: t(ny, nu, nfreq), dt(ny, nu, nfreq, nq)
    t_re = 0.0_wp
    t_im = 0.0_wp
    dt_re = 0.0_wp
    dt_im = 0.0_wp
    gain = 0.0_wp
    phase = 0.0_wp
    sgain = 0.0_wp
    sphase = 0.0_wp
    call model_create(mkind, nx, nu, ny, nw, iconst, rconst, m, status, msg)
    if (status /= MLID_OK) return
    call model_response(m, theta, w, jac, t, dt, status, msg)
    if (status /= MLID_OK) return
    call response_bands(t, dt, cov, gain, phase, sgain, sphase)
    t_re = real(t)
    t_im = aimag(t)
    dt_re = real(dt)
    dt_im = aimag(dt)
  end subroutine mlid_model_freq_response

  !> Weights of the transfer-function mismatch: 1, or by coherence.
  pure function tf_weights(coh, use_coh) result(wt)
    real(c_double), intent(in) :: coh(:)
    integer(c_int), intent(in) :: use_coh
    real(wp) :: wt(size(coh))
    wt = 1.0_wp
    if (use_coh /= 0) wt = coherence_weight(coh)
  end function tf_weights

  !> Fit T(s) = N(s)/D(s) e^(-tau s) (orders m, n; delay when delay = 1)
  !> to gain (dB) and phase (deg) at w (rad/s) by the handling-qualities
  !> mismatch (mlid_transfer_fit), weighted by coherence when use_coh = 1;
  !> from x0 when use_start = 1, else from Levy's least squares with the
  !> delay at tau0.  x: [b_0..b_m, a_0..a_(n-1), tau]; xs the start used.
  !> Parameters with isfree = 0 keep their value in x0.
  subroutine mlid_tf_fit(nfreq, w, gain, phase, coh, use_coh, m, n, delay, tau0, use_start, &
                         np, x0, isfree, max_iter, xs, x, cov, cost, niter, status, msg)
    integer(c_int), intent(in) :: nfreq, use_coh, m, n, delay, use_start, np, max_iter
    integer(c_int), intent(in) :: isfree(np)
    real(c_double), intent(in) :: w(nfreq), gain(nfreq), phase(nfreq), coh(nfreq), tau0, x0(np)
    real(c_double), intent(out) :: xs(np), x(np), cov(np, np), cost
    integer(c_int), intent(out) :: niter, status
    character(len=256), intent(out) :: msg
    real(wp) :: xw(np), cw(np, np), cst
    integer :: it
    xs = 0.0_wp
    x = 0.0_wp
    cov = 0.0_wp
    cost = 0.0_wp
    niter = 0
    call tf_check(nfreq, w, gain, phase, m, n, delay, np, status, msg)
    if (status /= MLID_OK) return
    if (use_start /= 0) then
      xw = x0
    else
      xw = x0                                           ! the fixed ones' values
      call tf_start(m, n, delay /= 0, tau0, w, gain, phase, tf_weights(coh, use_coh), isfree /= 0, &
                    xw, status, msg)
      if (status /= MLID_OK) return
    end if
    xs = xw
    call tf_fit(m, n, delay /= 0, w, gain, phase, tf_weights(coh, use_coh), isfree /= 0, max_iter, &
                xw, cst, cw, it, status, msg)
    x = xw
    cov = cw
    cost = cst
    niter = it
  end subroutine mlid_tf_fit

  !> Orders, sizes and frequencies of a transfer-function fit.
  subroutine tf_check(nfreq, w, gain, phase, m, n, delay, np, status, msg)
    integer(c_int), intent(in) :: nfreq, m, n, delay, np
    real(c_double), intent(in) :: w(:), gain(:), phase(:)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call tf_orders(m, n, delay, np, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (2*nfreq < np + 1) then
      write (msg, '(a,i0,a,i0,a)') 'transfer-function fit: ', nfreq, &
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

  !> The mismatch's residuals r (2 nfreq, r'r = cost) and their Jacobian.
  subroutine mlid_tf_residuals(nfreq, w, gain, phase, coh, use_coh, m, n, delay, np, x, r, jr, &
                               status, msg)
    integer(c_int), intent(in) :: nfreq, use_coh, m, n, delay, np
    real(c_double), intent(in) :: w(nfreq), gain(nfreq), phase(nfreq), coh(nfreq), x(np)
    real(c_double), intent(out) :: r(2*nfreq), jr(2*nfreq, np)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    r = 0.0_wp
    jr = 0.0_wp
    call tf_orders(m, n, delay, np, status, msg)
    if (status /= MLID_OK) return
    call tf_residuals(m, n, delay /= 0, x, w, gain, phase, tf_weights(coh, use_coh), r, jr)
  end subroutine mlid_tf_residuals

  !> Orders m >= 0, n >= 1 and np = tf_size, the length of x: the
  !> parameters b_0..b_m, a_0..a_(n-1) and tau when delay = 1.
  subroutine tf_orders(m, n, delay, np, status, msg)
    integer(c_int), intent(in) :: m, n, delay, np
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
