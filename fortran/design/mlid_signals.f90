!> Flight-test input signals on t = (k-1)*dt, k = 1..nt: orthogonal
!> multisines with minimised relative peak factor, frequency sweeps,
!> maximal-length PRBS, and the finishing every signal may get (zero mean
!> and zero ends, an amplitude limit).
!>
!> Multisines use the harmonics k/T of T = nt*dt, so that on the sampled
!> grid distinct harmonics are orthogonal exactly (up to rounding): each
!> input owns every m-th harmonic of the band (interleaved).
module mlid_signals
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_MEMORY
  use mlid_text, only: es_text, itoa
  implicit none
  private
  public :: multisine_band, multisine, peak_factor, sweep, prbs, finish_signal
  public :: SIGNAL_SHAPES, MULTISINE_ITERATIONS

  !> the shapes a deck's &simulate input_shape takes besides mlid_inputs'
  character(len=*), parameter :: SIGNAL_SHAPES = 'multisine, sweep, log_sweep, prbs'
  !> clipping/projection steps of a deck's multisines (Python's default too)
  integer, parameter :: MULTISINE_ITERATIONS = 1000

  real(wp), parameter :: PI = 3.14159265358979323846264338327950288_wp
  real(wp), parameter :: TWOPI = 2.0_wp*PI
  !> clip level of the projection iteration, a fraction of the half range
  real(wp), parameter :: CLIP = 0.9_wp

contains

  !> The harmonic numbers k (f = k/(nt*dt)) in [f_min, f_max], below Nyquist,
  !> and the input owning each (interleaved: the j-th harmonic goes to input
  !> mod(j-1, m)+1).
  subroutine multisine_band(f_min, f_max, dt, nt, m, k, owner, status, msg)
    real(wp), intent(in) :: f_min, f_max, dt
    integer, intent(in) :: nt, m
    integer, allocatable, intent(out) :: k(:), owner(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: t
    integer :: k1, k2, j, ierr

    status = MLID_ERR_INPUT
    msg = ''
    allocate (k(0), owner(0))
    if (.not. (ieee_is_finite(f_min) .and. ieee_is_finite(f_max) .and. ieee_is_finite(dt))) then
      msg = 'multisine: f_min, f_max and dt must be finite'
      return
    end if
    if (.not. dt > 0.0_wp .or. nt < 4 .or. m < 1) then
      msg = 'multisine: need dt > 0, at least 4 samples and at least one input'
      return
    end if
    if (.not. (f_min >= 0.0_wp .and. f_max > f_min)) then
      msg = 'multisine: need 0 <= f_min < f_max'
      return
    end if
    t = real(nt, wp)*dt
    k1 = max(1, ceiling(f_min*t - 1.0e-9_wp))
    k2 = min((nt - 1)/2, floor(f_max*t + 1.0e-9_wp))
    if (k2 - k1 + 1 < m) then
      msg = 'multisine: the band ['//trim(es_text(f_min, 10, 3))//','//trim(es_text(f_max, 10, 3))// &
            '] Hz holds '//itoa(max(0, k2 - k1 + 1))//' harmonics of 1/T (T ='// &
            trim(es_text(t, 10, 3))//' s) below Nyquist, fewer than the '//itoa(m)//' inputs'
      return
    end if
    deallocate (k, owner)
    allocate (k(k2 - k1 + 1), owner(k2 - k1 + 1), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'multisine: out of memory'
      return
    end if
    k = [(j, j=k1, k2)]
    owner = [(mod(j, m) + 1, j=0, k2 - k1)]
    status = MLID_OK
  end subroutine multisine_band

  !> One input's sum of cosines u(i) = sum_j a(j) cos(2 pi k(j) (i-1)/nt + ph(j)),
  !> from a table of one period of cos and sin (index mod nt: exact periodicity).
  subroutine synthesise(k, a, ph, ctab, stab, u)
    integer, intent(in) :: k(:)
    real(wp), intent(in) :: a(:), ph(:), ctab(0:), stab(0:)
    real(wp), intent(out) :: u(:)
    integer :: i, j, nt, idx
    real(wp) :: c, s
    nt = size(u)
    u = 0.0_wp
    do j = 1, size(k)
      c = a(j)*cos(ph(j))
      s = a(j)*sin(ph(j))
      do i = 1, nt
        idx = int(mod(int(k(j), kind=8)*int(i - 1, kind=8), int(nt, kind=8)))
        u(i) = u(i) + c*ctab(idx) - s*stab(idx)
      end do
    end do
  end subroutine synthesise

  !> RPF = (max - min) / (2 sqrt(2) rms); 0 for a zero signal.
  pure function peak_factor(u) result(r)
    real(wp), intent(in) :: u(:)
    real(wp) :: r, rms
    rms = sqrt(sum(u**2)/real(max(1, size(u)), wp))
    r = 0.0_wp
    if (rms > 0.0_wp) r = (maxval(u) - minval(u))/(2.0_wp*sqrt(2.0_wp)*rms)
  end function peak_factor

  !> Schroeder's phases for relative powers p (sum 1) on harmonics k:
  !> ph(n) = ph(n-1) - 2 pi (k(n)-k(n-1)) * sum(p(1:n-1)) (his eq. 5 in
  !> harmonic numbers, valid for any spacing).
  pure subroutine schroeder_phases(k, p, ph)
    integer, intent(in) :: k(:)
    real(wp), intent(in) :: p(:)
    real(wp), intent(out) :: ph(:)
    integer :: n
    ph(1) = 0.0_wp
    do n = 2, size(k)
      ph(n) = modulo(ph(n - 1) - TWOPI*real(k(n) - k(n - 1), wp)*sum(p(1:n - 1)), TWOPI)
    end do
  end subroutine schroeder_phases

  !> Clipping/projection: clip u about its mid-range at CLIP of its half
  !> range, keep the amplitudes, take the phases of the clipped signal's
  !> Fourier coefficients at k; the best phases seen are returned.
  subroutine clip_project(k, a, ctab, stab, iters, ph, u)
    integer, intent(in) :: k(:), iters
    real(wp), intent(in) :: a(:), ctab(0:), stab(0:)
    real(wp), intent(inout) :: ph(:)
    real(wp), intent(inout) :: u(:)
    real(wp) :: best, r, mid, half, re, im, trial(size(ph))
    integer :: it, i, j, idx, nt
    nt = size(u)
    call synthesise(k, a, ph, ctab, stab, u)
    best = peak_factor(u)
    trial = ph
    do it = 1, iters
      mid = 0.5_wp*(maxval(u) + minval(u))
      half = 0.5_wp*(maxval(u) - minval(u))
      u = min(max(u, mid - CLIP*half), mid + CLIP*half)
      do j = 1, size(k)
        re = 0.0_wp
        im = 0.0_wp
        do i = 1, nt
          idx = int(mod(int(k(j), kind=8)*int(i - 1, kind=8), int(nt, kind=8)))
          re = re + u(i)*ctab(idx)
          im = im - u(i)*stab(idx)
        end do
        if (re /= 0.0_wp .or. im /= 0.0_wp) trial(j) = atan2(im, re)
      end do
      call synthesise(k, a, trial, ctab, stab, u)
      r = peak_factor(u)
      if (r < best) then
        best = r
        ph = trial
      end if
    end do
    call synthesise(k, a, ph, ctab, stab, u)
  end subroutine clip_project

  !> Shift the sum of cosines in time so that it starts (and, being
  !> periodic in T, ends) at zero: the first sign change of the samples,
  !> refined by Newton on the continuous sum; phases ph(j) += 2 pi k(j) t0/nt
  !> (t0 in samples) keep the amplitudes, hence orthogonality and spectrum.
  subroutine shift_to_zero(k, a, ph, nt)
    integer, intent(in) :: k(:), nt
    real(wp), intent(in) :: a(:)
    real(wp), intent(inout) :: ph(:)
    real(wp) :: t0, w(size(k)), f, df, u0, u1
    integer :: i, it
    w = TWOPI*real(k, wp)/real(nt, wp)
    u0 = sum(a*cos(ph))
    t0 = 0.0_wp
    do i = 1, nt
      u1 = sum(a*cos(w*real(i, wp) + ph))
      if (u0 == 0.0_wp) exit
      if (sign(1.0_wp, u0) /= sign(1.0_wp, u1)) then
        t0 = real(i - 1, wp) + u0/(u0 - u1)
        exit
      end if
      u0 = u1
    end do
    do it = 1, 8
      f = sum(a*cos(w*t0 + ph))
      df = -sum(a*w*sin(w*t0 + ph))
      if (df == 0.0_wp) exit
      t0 = t0 - f/df
    end do
    ph = modulo(ph + w*t0, TWOPI)
  end subroutine shift_to_zero

  !> m mutually orthogonal multisines on the band's harmonics (multisine_band)
  !> of T = nt*dt, on t = 0, dt, ..., T (nt+1 rows of u: the last repeats the
  !> first, zero, as the inputs start and end at zero; RPFs over one period):
  !> relative powers pw (one per band harmonic, each input's normalised to
  !> sum 1), Schroeder phases, then iters clipping/projection steps, a time
  !> shift to start and end at zero, and a scale to peak |u| = amp(input).
  !> rpf0/rpf: each input's RPF with Schroeder phases / as returned;
  !> ph: each harmonic's phase of cos; ampl: each harmonic's amplitude.
  subroutine multisine(k, owner, pw, amp, iters, u, ph, ampl, rpf0, rpf, status, msg)
    integer, intent(in) :: k(:), owner(:), iters
    real(wp), intent(in) :: pw(:), amp(:)
    real(wp), intent(out) :: u(:, :), ph(:), ampl(:), rpf0(:), rpf(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: ctab(:), stab(:), p(:), phj(:)
    integer, allocatable :: idx(:)
    integer :: nt, m, j, i, ierr

    status = MLID_ERR_INPUT
    msg = ''
    u = 0.0_wp
    ph = 0.0_wp
    ampl = 0.0_wp
    rpf0 = 0.0_wp
    rpf = 0.0_wp
    nt = size(u, 1) - 1
    m = size(u, 2)
    if (any(.not. ieee_is_finite(pw)) .or. any(pw < 0.0_wp)) then
      msg = 'multisine: the relative powers must be finite and >= 0'
      return
    end if
    if (any(.not. ieee_is_finite(amp)) .or. any(.not. amp > 0.0_wp)) then
      msg = 'multisine: the amplitudes must be finite and > 0'
      return
    end if
    if (iters < 0) then
      msg = 'multisine: iterations must be >= 0'
      return
    end if
    allocate (ctab(0:nt - 1), stab(0:nt - 1), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'multisine: out of memory'
      return
    end if
    ctab = cos(TWOPI*[(real(i, wp), i=0, nt - 1)]/real(nt, wp))
    stab = sin(TWOPI*[(real(i, wp), i=0, nt - 1)]/real(nt, wp))
    do j = 1, m
      idx = pack([(i, i=1, size(k))], owner == j)
      p = pw(idx)
      if (.not. sum(p) > 0.0_wp) then
        msg = 'multisine: input '//itoa(j)//' has no power on its harmonics'
        return
      end if
      p = p/sum(p)
      ampl(idx) = sqrt(2.0_wp*p)
      allocate (phj(size(idx)))
      call schroeder_phases(k(idx), p, phj)
      call synthesise(k(idx), ampl(idx), phj, ctab, stab, u(1:nt, j))
      rpf0(j) = peak_factor(u(1:nt, j))
      call clip_project(k(idx), ampl(idx), ctab, stab, iters, phj, u(1:nt, j))
      call shift_to_zero(k(idx), ampl(idx), phj, nt)
      call synthesise(k(idx), ampl(idx), phj, ctab, stab, u(1:nt, j))
      u(nt + 1, j) = u(1, j)
      rpf(j) = peak_factor(u(1:nt, j))
      ampl(idx) = ampl(idx)*amp(j)/maxval(abs(u(:, j)))
      u(:, j) = u(:, j)*amp(j)/maxval(abs(u(:, j)))
      ph(idx) = phj
      deallocate (phj)
    end do
    status = MLID_OK
  end subroutine multisine

  !> A sine sweep from f0 to f1 over the whole record (kind 'linear': f(t)
  !> linear in t; 'log': f(t) = f0 (f1/f0)^(t/T)), amplitude going linearly
  !> from a0 to a1, with raised-cosine fades of t_fade at both ends.
  subroutine sweep(kind, f0, f1, a0, a1, t_fade, dt, u, status, msg)
    character(len=*), intent(in) :: kind
    real(wp), intent(in) :: f0, f1, a0, a1, t_fade, dt
    real(wp), intent(out) :: u(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: t, tt, phase, env, r
    integer :: i, nt

    status = MLID_ERR_INPUT
    msg = ''
    u = 0.0_wp
    nt = size(u)
    if (.not. all(ieee_is_finite([f0, f1, a0, a1, t_fade, dt]))) then
      msg = 'sweep: frequencies, amplitudes, fade and dt must be finite'
      return
    end if
    if (.not. dt > 0.0_wp .or. nt < 2) then
      msg = 'sweep: need dt > 0 and at least 2 samples'
      return
    end if
    if (.not. (f0 > 0.0_wp .and. f1 > 0.0_wp) .or. max(f0, f1) > 0.5_wp/dt) then
      msg = 'sweep: the frequencies must be > 0 and at most Nyquist'
      return
    end if
    tt = real(nt - 1, wp)*dt
    if (t_fade < 0.0_wp .or. 2.0_wp*t_fade > tt) then
      msg = 'sweep: the fade must be >= 0 and at most half the record'
      return
    end if
    if (kind /= 'linear' .and. kind /= 'log') then
      msg = 'sweep: unknown kind '''//trim(kind)//''': use linear, log'
      return
    end if
    r = f1/f0
    do i = 1, nt
      t = real(i - 1, wp)*dt
      if (kind == 'linear' .or. abs(r - 1.0_wp) < 1.0e-12_wp) then
        phase = TWOPI*(f0*t + 0.5_wp*(f1 - f0)*t*t/tt)
      else
        phase = TWOPI*f0*tt/log(r)*(r**(t/tt) - 1.0_wp)
      end if
      env = 1.0_wp
      if (t_fade > 0.0_wp) env = fade(min(t, tt - t)/t_fade)
      u(i) = (a0 + (a1 - a0)*t/tt)*env*sin(phase)
    end do
    status = MLID_OK
  end subroutine sweep

  !> Raised-cosine ramp: 0 at x = 0, 1 from x = 1 on.
  pure function fade(x) result(g)
    real(wp), intent(in) :: x
    real(wp) :: g
    g = 1.0_wp
    if (x < 1.0_wp) g = 0.5_wp*(1.0_wp - cos(PI*max(x, 0.0_wp)))
  end function fade

  !> A maximal-length sequence of order n (period 2^n - 1) from a Fibonacci
  !> shift register with a primitive feedback polynomial, each bit held for
  !> nclock samples, +a for a 1 and -a for a 0, repeated to fill u.
  subroutine prbs(n, nclock, a, u, status, msg)
    integer, intent(in) :: n, nclock
    real(wp), intent(in) :: a
    real(wp), intent(out) :: u(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    ! taps (exponents of x besides x^n and 1) of primitive polynomials, n = 2..20
    integer, parameter :: TAPS(3, 2:20) = reshape([ &
      1, 0, 0,  1, 0, 0,  1, 0, 0,  2, 0, 0,  1, 0, 0,  1, 0, 0,  6, 5, 4, &
      4, 0, 0,  3, 0, 0,  2, 0, 0,  6, 4, 1,  4, 3, 1,  5, 3, 1,  1, 0, 0, &
      5, 3, 2,  3, 0, 0,  7, 0, 0,  5, 2, 1,  3, 0, 0], [3, 19])
    logical :: reg(20), bit
    integer :: i, j

    status = MLID_ERR_INPUT
    msg = ''
    u = 0.0_wp
    if (n < 2 .or. n > 20) then
      msg = 'prbs: the order must be 2 to 20, got '//itoa(n)
      return
    end if
    if (nclock < 1) then
      msg = 'prbs: the clock period must be at least one sample'
      return
    end if
    if (.not. ieee_is_finite(a)) then
      msg = 'prbs: the amplitude must be finite'
      return
    end if
    reg = .false.
    reg(1:n) = .true.
    do i = 1, size(u), nclock
      u(i:min(size(u), i + nclock - 1)) = merge(a, -a, reg(n))
      ! x^n + sum x^t + 1: the new bit is the output xor the tapped stages
      bit = reg(n)
      do j = 1, 3
        if (TAPS(j, n) > 0) bit = bit .neqv. reg(TAPS(j, n))
      end do
      reg(2:n) = reg(1:n - 1)
      reg(1) = bit
    end do
    status = MLID_OK
  end subroutine prbs

  !> Finishing: with zero, remove the endpoint line (u(1) = u(nt) = 0) and
  !> then the mean with a half-sine bump (which keeps the ends at zero);
  !> with limit > 0, scale the whole signal down so that max |u| <= limit
  !> (scaled, not clipped: the shape and spectrum stay).
  subroutine finish_signal(u, zero, limit, status, msg)
    real(wp), intent(inout) :: u(:)
    logical, intent(in) :: zero
    real(wp), intent(in) :: limit
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: s, bump(size(u)), peak, u1, un
    integer :: i, nt

    status = MLID_ERR_INPUT
    msg = ''
    nt = size(u)
    if (.not. (ieee_is_finite(limit) .and. limit >= 0.0_wp)) then
      msg = 'signal limit must be finite and >= 0 (0: no limit)'
      return
    end if
    if (zero .and. nt >= 3) then
      u1 = u(1)
      un = u(nt)
      do i = 1, nt
        s = real(i - 1, wp)/real(nt - 1, wp)
        u(i) = u(i) - (u1*(1.0_wp - s) + un*s)
        bump(i) = sin(PI*s)
      end do
      u(1) = 0.0_wp
      u(nt) = 0.0_wp
      bump(1) = 0.0_wp
      bump(nt) = 0.0_wp
      u = u - (sum(u)/sum(bump))*bump
    end if
    peak = maxval(abs(u))
    if (limit > 0.0_wp .and. peak > limit) u = u*(limit/peak)
    status = MLID_OK
  end subroutine finish_signal

end module mlid_signals
