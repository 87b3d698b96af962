!> Global Fourier smoothing and the smoothed derivative of one uniformly
!> sampled channel (in the manner of Morelli's SIDPAC smoo/deriv; own code).
!>
!> 1. The straight line through the first and last samples is removed, so
!>    the rest x~ is 0 at both ends; its odd mirror image (x~ then -x~
!>    reversed, period M = 2(n-1)) is continuous with a continuous slope at
!>    the ends, so the ends do not ring (its spectrum falls as 1/k^3).
!> 2. The mirror's DFT Y(k), k = 0 .. n-1 (a sine series), its power P(k).
!> 3. The cut-off (THE RULE): the noise floor F is the median of P(k) over
!>    the upper half of the bins (n/2 < k < n-1) divided by 0.4549 (the
!>    median of chi-square with one degree of freedom over its mean), i.e.
!>    the mean power of white noise; the spectrum's mean over the bins
!>    k - h .. k + h, h = max(4, k/2) (+-50% in frequency: it bridges the
!>    gaps between the lines of a sum of sines) is followed up from its
!>    largest value; the cut-off bin kc is the first bin where it is at or below
!>    FLOOR_FACTOR = 10 times F: where the signal's spectrum meets the noise
!>    floor.  (The first meeting, not the last: real records' spectra carry
!>    vibration peaks and coloured noise above the smooth manoeuvre's band.)
!>    Never met: kc = n - 2 (no smoothing).  A cut-off given in Hz
!>    overrides the rule: kc = nint(fc 2 (n-1) dt).
!> 4. The filter: 1 up to kc, a raised cosine down to 0 at kc + r,
!>    r = max(2, kc/4) bins (a brick wall would ring).
!> 5. Smooth: the filtered mirror transformed back, the line added back.
!>    Derivative: the filtered mirror times i w(k) transformed back (exact
!>    for the sine series), the line's slope added back.
!> The bin k is the frequency k/(2 (n-1) dt).  The mirror's period is any
!> length: its DFT is by the FFT when M is 2^a 3^b 5^c, else by
!> Bluestein's chirp-z through one of such a length (mlid_fft's fft_any_length).
module mlid_smooth
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_MEMORY, MLID_ERR_INTERRUPTED
  use mlid_interrupt, only: interrupt_requested
  use mlid_text, only: seconds, itoa
  use mlid_fft, only: fft_any_length
  use mlid_sampling, only: median
  implicit none
  private
  public :: smooth_fourier, SMOOTH_MIN_SAMPLES, smooth_uniform_check

  !> Fewer samples give no upper half of bins to measure the noise floor on.
  integer, parameter :: SMOOTH_MIN_SAMPLES = 16
  real(wp), parameter :: FLOOR_FACTOR = 10.0_wp
  real(wp), parameter :: CHI2_MEDIAN = 0.4549364231195724_wp  !< median of chi2(1)
  integer, parameter :: MIN_HALF_WINDOW = 4
  !> A step differing from the mean step by more than this fraction is not uniform.
  real(wp), parameter :: STEP_TOLERANCE = 0.01_wp
  real(wp), parameter :: PI = 4.0_wp*atan(1.0_wp)

contains

  !> The smoothed x (xs) and its derivative (xd) of x sampled at step dt;
  !> kc the cut-off bin, fc the cut-off frequency [Hz] (the rule's, or
  !> fc_given's when > 0).  status/msg: too few samples, or a step not > 0.
  subroutine smooth_fourier(x, dt, xs, xd, kc, fc, status, msg, fc_given)
    real(wp), intent(in) :: x(:), dt
    real(wp), intent(in), optional :: fc_given
    real(wp), intent(out) :: xs(size(x)), xd(size(x))
    integer, intent(out) :: kc
    real(wp), intent(out) :: fc
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    complex(wp), allocatable :: y(:), yd(:)
    real(wp), allocatable :: p(:), w(:)
    real(wp) :: slope, tk
    integer :: n, m, k, ist
    logical :: ok(3)

    n = size(x)
    xs = 0.0_wp
    xd = 0.0_wp
    kc = 0
    fc = 0.0_wp
    status = MLID_ERR_INPUT
    if (n < SMOOTH_MIN_SAMPLES) then
      msg = 'smoothing needs at least '//itoa(SMOOTH_MIN_SAMPLES)//' samples, '//itoa(n)//' given'
      return
    end if
    if (.not. dt > 0.0_wp) then
      msg = 'smoothing needs a time step > 0'
      return
    end if
    m = 2*(n - 1)
    allocate (y(0:m - 1), yd(0:m - 1), p(0:n - 1), w(0:n - 1), stat=ist)
    if (ist /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'smoothing: out of memory'
      return
    end if
    slope = (x(n) - x(1))/(n - 1)
    do k = 0, n - 1
      y(k) = x(k + 1) - x(1) - slope*k
    end do
    do k = 1, n - 2
      y(m - k) = -y(k)
    end do
    call fft_any_length(y, .false., ok(1))
    p = abs(y(0:n - 1))**2
    kc = cutoff(p)
    if (present(fc_given)) then
      if (fc_given > 0.0_wp) kc = max(1, min(n - 1, nint(fc_given*m*dt)))
    end if
    w = weights(n, kc)
    yd(0) = 0.0_wp
    y(0) = w(0)*y(0)
    do k = 1, n - 1
      y(k) = w(k)*y(k)
      if (k < n - 1) y(m - k) = w(k)*y(m - k)
      tk = 2.0_wp*PI*k/(m*dt)
      yd(k) = cmplx(0.0_wp, tk, wp)*y(k)
      if (k < n - 1) yd(m - k) = cmplx(0.0_wp, -tk, wp)*y(m - k)
    end do
    yd(n - 1) = 0.0_wp                       ! Nyquist: its derivative has no sign
    call fft_any_length(y, .true., ok(2))
    call fft_any_length(yd, .true., ok(3))
    if (.not. all(ok)) then
      status = MLID_ERR_MEMORY
      msg = 'smoothing: out of memory'
      return
    end if
    if (interrupt_requested()) then          ! a transform cut short (mlid_fft)
      status = MLID_ERR_INTERRUPTED
      msg = 'interrupted'
      return
    end if
    do k = 0, n - 1
      xs(k + 1) = real(y(k), wp)/m + x(1) + slope*k
      xd(k + 1) = real(yd(k), wp)/m + slope/dt
    end do
    fc = kc/(m*dt)
    status = MLID_OK
    msg = ''
  end subroutine smooth_fourier

  !> The cut-off bin of step 3 from the mirror's power p(0:n-1).
  integer function cutoff(p) result(kc)
    real(wp), intent(in) :: p(0:)
    real(wp) :: floor, csum(0:size(p) - 2), avg(size(p) - 2)
    integer :: n, k, lo, hi, h
    n = size(p)
    floor = median(p(n/2 + 1:n - 2))/CHI2_MEDIAN
    csum(0) = 0.0_wp                         ! csum(k) = p(1) + .. + p(k)
    do k = 1, n - 2
      csum(k) = csum(k - 1) + p(k)
    end do
    do k = 1, n - 2
      h = max(MIN_HALF_WINDOW, k/2)
      lo = max(1, k - h)
      hi = min(n - 2, k + h)
      avg(k) = (csum(hi) - csum(lo - 1))/(hi - lo + 1)
    end do
    do k = maxloc(avg, 1), n - 2
      if (avg(k) <= FLOOR_FACTOR*floor) then
        kc = k
        return
      end if
    end do
    kc = n - 2
  end function cutoff

  !> The filter of step 4 on bins 0 .. n-1.
  pure function weights(n, kc) result(w)
    integer, intent(in) :: n, kc
    real(wp) :: w(0:n - 1)
    integer :: k, r
    r = max(2, kc/4)
    do k = 0, n - 1
      if (k <= kc) then
        w(k) = 1.0_wp
      else if (k < kc + r) then
        w(k) = 0.5_wp*(1.0_wp + cos(PI*(k - kc)/r))
      else
        w(k) = 0.0_wp
      end if
    end do
  end function weights

  !> The step of a uniform time t (its mean step); 0 and a message naming
  !> the first sample where a step differs from the mean by more than
  !> STEP_TOLERANCE of it.
  subroutine smooth_uniform_check(t, dt, at, msg)
    real(wp), intent(in) :: t(:)
    real(wp), intent(out) :: dt
    integer, intent(out) :: at
    character(len=*), intent(out) :: msg
    integer :: k
    msg = ''
    at = 0
    dt = 0.0_wp
    if (size(t) < 2) return
    dt = (t(size(t)) - t(1))/(size(t) - 1)
    do k = 2, size(t)
      if (abs(t(k) - t(k - 1) - dt) > STEP_TOLERANCE*abs(dt)) then
        at = k
        msg = 'the time is not uniform (step '//seconds(t(k) - t(k - 1))//', mean step '// &
              seconds(dt)//'): smoothing needs a uniform step (dt = ... rebuilds one)'
        dt = 0.0_wp
        return
      end if
    end do
  end subroutine smooth_uniform_check

end module mlid_smooth
