!> The discrete Fourier transform of a length n = 2^a 3^b 5^c:
!> Z(f) = sum_k z(k) exp(-2 pi i f k / n), k, f = 0 .. n-1, by Stockham's
!> autosort (decimation in frequency, no bit reversal) in stages of radix
!> 4, 2, 3 and 5, many series at once: the series index runs innermost, so
!> each butterfly is one long contiguous loop over all series (and, in the
!> later stages, over the stride) with one set of twiddles, real and
!> imaginary parts apart.  A plan holds the radices and twiddle factors of
!> one length, so many transforms share them.
!> A Ctrl-C (mlid_interrupt) cuts a transform short between its stages,
!> leaving no transform: a caller that has a status polls after it.
module mlid_fft
  use mlid_kinds, only: wp
  use mlid_interrupt, only: interrupt_requested
  implicit none
  private
  public :: fft_plan_t, fft_plan, fft_plan_into, fft_forward, fft_length, fft_smooth_length, fft_real_pair, &
            fft_many, fft_real_many, fft_any_length

  type :: fft_plan_t
    integer :: n = 0
    integer, allocatable :: radix(:)          !< the stages' radices, product n
    real(wp), allocatable :: wr(:), wi(:)     !< exp(-2 pi i k / n) = wr + i wi, k < n
  end type fft_plan_t

  !> Complex series per block of fft_real_many: a block's two buffers of
  !> 4 BLOCK n reals stay in a core's cache at the lengths of the records.
  integer, parameter :: BLOCK = 8
  !> Series-lengths of workspace one thread of fft_real_many allocates (its block's four)
  integer, parameter, public :: FFT_WORK_ROWS = 4*BLOCK
  !> The radices, in the order the stages take them.
  integer, parameter :: RADICES(4) = [4, 2, 3, 5]

contains

  !> The smallest power of two not below m.
  pure integer function fft_length(m) result(n)
    integer, intent(in) :: m
    n = 1
    do while (n < m)
      n = 2*n
    end do
  end function fft_length

  !> The smallest even n not below m with no prime factor but 2, 3 and 5
  !> (even: the real transforms' frequencies 0 .. n/2 end at Nyquist).
  pure integer function fft_smooth_length(m) result(n)
    integer, intent(in) :: m
    n = max(m, 2)
    do while (.not. smooth(n))
      n = n + 1
    end do
  contains
    pure logical function smooth(k)
      integer, intent(in) :: k
      integer :: j, r
      j = k
      do r = 2, 5
        do while (mod(j, r) == 0)
          j = j/r
        end do
      end do
      smooth = j == 1 .and. mod(k, 2) == 0
    end function smooth
  end function fft_smooth_length

  !> The plan for length n (2^a 3^b 5^c, as fft_length and fft_smooth_length give).
  pure function fft_plan(n) result(p)
    integer, intent(in) :: n
    type(fft_plan_t) :: p
    logical :: ok
    call fft_plan_into(n, p, ok)
  end function fft_plan

  !> fft_plan made in place: ok false (and p%n 0) when its twiddles do not
  !> fit in memory (a record's length: a plan's copy is an allocation too).
  pure subroutine fft_plan_into(n, p, ok)
    integer, intent(in) :: n
    type(fft_plan_t), intent(out) :: p
    logical, intent(out) :: ok
    real(wp), parameter :: two_pi = 8.0_wp*atan(1.0_wp)
    integer :: k, j, i, ist
    allocate (p%radix(0), p%wr(0:n - 1), p%wi(0:n - 1), stat=ist)
    ok = ist == 0
    if (.not. ok) return
    p%n = n
    j = n
    do i = 1, size(RADICES)
      do while (mod(j, RADICES(i)) == 0 .and. j > 1)
        p%radix = [p%radix, RADICES(i)]
        j = j/RADICES(i)
      end do
    end do
    do k = 0, n/2                             ! the rest their conjugates
      p%wr(k) = cos(two_pi*k/n)
      p%wi(k) = -sin(two_pi*k/n)
    end do
    do k = n/2 + 1, n - 1
      p%wr(k) = p%wr(n - k)
      p%wi(k) = -p%wi(n - k)
    end do
    if (mod(n, 4) == 0) then                  ! exactly -i, -1, i
      p%wr(n/4) = 0.0_wp
      p%wr(3*n/4) = 0.0_wp
      p%wi(n/2) = 0.0_wp
    end if
  end subroutine fft_plan_into

  !> z = DFT(z), z(0:n-1), n = p%n.
  subroutine fft_forward(p, z)
    type(fft_plan_t), intent(in) :: p
    complex(wp), intent(inout) :: z(0:)
    real(wp), allocatable :: zr(:), zi(:)
    allocate (zr(p%n), zi(p%n))
    zr = real(z(0:p%n - 1), wp)
    zi = aimag(z(0:p%n - 1))
    call fft_many(p, 1, zr, zi)
    z(0:p%n - 1) = cmplx(zr, zi, wp)
  end subroutine fft_forward

  !> The transforms of m complex series in place, series j's sample k at
  !> zr(j, k) + i zi(j, k) (arrays m x n, k = 0 .. n-1): one stage per
  !> radix between z and a buffer, each series' values the same whatever m is.
  subroutine fft_many(p, m, zr, zi)
    type(fft_plan_t), intent(in) :: p
    integer, intent(in) :: m
    real(wp), intent(inout) :: zr(m*p%n), zi(m*p%n)
    real(wp), allocatable :: yr(:), yi(:)     ! the buffer (on the heap: long records)
    logical :: in_y
    allocate (yr(m*p%n), yi(m*p%n))
    call stages(p, m, zr, zi, yr, yi, in_y)
    if (in_y) then
      zr = yr
      zi = yi
    end if
  end subroutine fft_many

  !> fft_many between z and the buffer y, the transforms left in y when
  !> in_y (an odd number of stages), else in z.
  subroutine stages(p, m, zr, zi, yr, yi, in_y)
    type(fft_plan_t), intent(in) :: p
    integer, intent(in) :: m
    real(wp), intent(inout) :: zr(m*p%n), zi(m*p%n)
    real(wp), intent(out) :: yr(m*p%n), yi(m*p%n)
    logical, intent(out) :: in_y
    integer :: s, i
    s = 1                                     ! stride: transforms of n/s points, s of them
    in_y = .false.
    do i = 1, size(p%radix)
      if (interrupt_requested()) exit        ! (a stage of a long record: tens of ms)
      if (in_y) then
        call stage(p, p%radix(i), m*s, s, yr, yi, zr, zi)
      else
        call stage(p, p%radix(i), m*s, s, zr, zi, yr, yi)
      end if
      in_y = .not. in_y
      s = s*p%radix(i)
    end do
  end subroutine stages

  !> One stage of radix r at stride s: x holds r h blocks of c = m s values
  !> (h = n/(r s)); block p + h j, j < r, make the r-point transforms whose
  !> k-th, turned by exp(-2 pi i p k s / n), goes to block r p + k of y.
  !> (ivdep in the stages: the blocks do not overlap, which gcc cannot
  !> prove for a c known only at run time; without it the radix-4 and -5
  !> loops would need more run-time overlap checks than it makes, and stay
  !> scalar.)
  pure subroutine stage(p, r, c, s, xr, xi, yr, yi)
    type(fft_plan_t), intent(in) :: p
    integer, intent(in) :: r, c, s
    real(wp), intent(in) :: xr((c/s)*p%n), xi((c/s)*p%n)      ! c/s first: no overflow
    real(wp), intent(out) :: yr((c/s)*p%n), yi((c/s)*p%n)
    integer :: h
    h = p%n/(r*s)
    select case (r)
    case (2)
      call stage2(c, h, s, p%wr, p%wi, xr, xi, yr, yi)
    case (3)
      call stage3(c, h, s, p%wr, p%wi, xr, xi, yr, yi)
    case (4)
      call stage4(c, h, s, p%wr, p%wi, xr, xi, yr, yi)
    case default
      call stage5(c, h, s, p%wr, p%wi, xr, xi, yr, yi)
    end select
  end subroutine stage

  pure subroutine stage2(c, h, s, wr, wi, xr, xi, yr, yi)
    integer, intent(in) :: c, h, s
    real(wp), intent(in) :: wr(0:), wi(0:), xr(c, 0:h - 1, 0:1), xi(c, 0:h - 1, 0:1)
    real(wp), intent(out) :: yr(c, 0:1, 0:h - 1), yi(c, 0:1, 0:h - 1)
    real(wp) :: cr, ci, dr, di
    integer :: j, k
    do j = 0, h - 1
      cr = wr(j*s)
      ci = wi(j*s)
      !GCC$ ivdep
      do k = 1, c
        yr(k, 0, j) = xr(k, j, 0) + xr(k, j, 1)
        yi(k, 0, j) = xi(k, j, 0) + xi(k, j, 1)
        dr = xr(k, j, 0) - xr(k, j, 1)
        di = xi(k, j, 0) - xi(k, j, 1)
        yr(k, 1, j) = dr*cr - di*ci
        yi(k, 1, j) = dr*ci + di*cr
      end do
    end do
  end subroutine stage2

  !> Radix 3: with u = a1 + a2, d = a1 - a2, b0 = a0 + u, b1,2 = a0 - u/2 -+ i sin(2 pi/3) d.
  pure subroutine stage3(c, h, s, wr, wi, xr, xi, yr, yi)
    integer, intent(in) :: c, h, s
    real(wp), intent(in) :: wr(0:), wi(0:), xr(c, 0:h - 1, 0:2), xi(c, 0:h - 1, 0:2)
    real(wp), intent(out) :: yr(c, 0:2, 0:h - 1), yi(c, 0:2, 0:h - 1)
    real(wp), parameter :: s3 = 0.5_wp*sqrt(3.0_wp)
    real(wp) :: c1, s1, c2, s2, ur, ui, dr, di, er, ei, fr, fi
    integer :: j, k
    do j = 0, h - 1
      c1 = wr(j*s)
      s1 = wi(j*s)
      c2 = wr(2*j*s)
      s2 = wi(2*j*s)
      !GCC$ ivdep
      do k = 1, c
        ur = xr(k, j, 1) + xr(k, j, 2)
        ui = xi(k, j, 1) + xi(k, j, 2)
        dr = s3*(xr(k, j, 1) - xr(k, j, 2))
        di = s3*(xi(k, j, 1) - xi(k, j, 2))
        yr(k, 0, j) = xr(k, j, 0) + ur
        yi(k, 0, j) = xi(k, j, 0) + ui
        er = xr(k, j, 0) - 0.5_wp*ur
        ei = xi(k, j, 0) - 0.5_wp*ui
        fr = er + di                           ! b1 = e - i d
        fi = ei - dr
        yr(k, 1, j) = fr*c1 - fi*s1
        yi(k, 1, j) = fr*s1 + fi*c1
        fr = er - di                           ! b2 = e + i d
        fi = ei + dr
        yr(k, 2, j) = fr*c2 - fi*s2
        yi(k, 2, j) = fr*s2 + fi*c2
      end do
    end do
  end subroutine stage3

  !> Radix 4: t0,1 = a0 +- a2, t2,3 = a1 +- a3; b0,2 = t0 +- t2, b1,3 = t1 -+ i t3.
  pure subroutine stage4(c, h, s, wr, wi, xr, xi, yr, yi)
    integer, intent(in) :: c, h, s
    real(wp), intent(in) :: wr(0:), wi(0:), xr(c, 0:h - 1, 0:3), xi(c, 0:h - 1, 0:3)
    real(wp), intent(out) :: yr(c, 0:3, 0:h - 1), yi(c, 0:3, 0:h - 1)
    real(wp) :: c1, s1, c2, s2, c3, s3, t0r, t0i, t1r, t1i, t2r, t2i, t3r, t3i, fr, fi
    integer :: j, k
    do j = 0, h - 1
      c1 = wr(j*s)
      s1 = wi(j*s)
      c2 = wr(2*j*s)
      s2 = wi(2*j*s)
      c3 = wr(3*j*s)
      s3 = wi(3*j*s)
      !GCC$ ivdep
      do k = 1, c
        t0r = xr(k, j, 0) + xr(k, j, 2)
        t0i = xi(k, j, 0) + xi(k, j, 2)
        t1r = xr(k, j, 0) - xr(k, j, 2)
        t1i = xi(k, j, 0) - xi(k, j, 2)
        t2r = xr(k, j, 1) + xr(k, j, 3)
        t2i = xi(k, j, 1) + xi(k, j, 3)
        t3r = xr(k, j, 1) - xr(k, j, 3)
        t3i = xi(k, j, 1) - xi(k, j, 3)
        yr(k, 0, j) = t0r + t2r
        yi(k, 0, j) = t0i + t2i
        fr = t0r - t2r
        fi = t0i - t2i
        yr(k, 2, j) = fr*c2 - fi*s2
        yi(k, 2, j) = fr*s2 + fi*c2
        fr = t1r + t3i
        fi = t1i - t3r
        yr(k, 1, j) = fr*c1 - fi*s1
        yi(k, 1, j) = fr*s1 + fi*c1
        fr = t1r - t3i
        fi = t1i + t3r
        yr(k, 3, j) = fr*c3 - fi*s3
        yi(k, 3, j) = fr*s3 + fi*c3
      end do
    end do
  end subroutine stage4

  !> Radix 5: with u1,2 = a1 +- a4, u3,4 = a2 +- a3 (c_k = cos(2 pi k/5),
  !> s_k = sin(2 pi k/5)): b1,4 = a0 + c1 u1 + c2 u3 -+ i (s1 u2 + s2 u4),
  !> b2,3 = a0 + c2 u1 + c1 u3 -+ i (s2 u2 - s1 u4).
  pure subroutine stage5(c, h, s, wr, wi, xr, xi, yr, yi)
    integer, intent(in) :: c, h, s
    real(wp), intent(in) :: wr(0:), wi(0:), xr(c, 0:h - 1, 0:4), xi(c, 0:h - 1, 0:4)
    real(wp), intent(out) :: yr(c, 0:4, 0:h - 1), yi(c, 0:4, 0:h - 1)
    real(wp), parameter :: two_pi = 8.0_wp*atan(1.0_wp)
    real(wp), parameter :: k1 = cos(two_pi/5), k2 = cos(2*two_pi/5), q1 = sin(two_pi/5), &
                           q2 = sin(2*two_pi/5)
    real(wp) :: tw(2, 4), u1r, u1i, u2r, u2i, u3r, u3i, u4r, u4i, er, ei, gr, gi, fr, fi
    integer :: j, k, i
    do j = 0, h - 1
      do i = 1, 4
        tw(:, i) = [wr(i*j*s), wi(i*j*s)]
      end do
      !GCC$ ivdep
      do k = 1, c
        u1r = xr(k, j, 1) + xr(k, j, 4)
        u1i = xi(k, j, 1) + xi(k, j, 4)
        u2r = xr(k, j, 1) - xr(k, j, 4)
        u2i = xi(k, j, 1) - xi(k, j, 4)
        u3r = xr(k, j, 2) + xr(k, j, 3)
        u3i = xi(k, j, 2) + xi(k, j, 3)
        u4r = xr(k, j, 2) - xr(k, j, 3)
        u4i = xi(k, j, 2) - xi(k, j, 3)
        yr(k, 0, j) = xr(k, j, 0) + u1r + u3r
        yi(k, 0, j) = xi(k, j, 0) + u1i + u3i
        er = xr(k, j, 0) + k1*u1r + k2*u3r     ! b1, b4 = e -+ i g
        ei = xi(k, j, 0) + k1*u1i + k2*u3i
        gr = q1*u2r + q2*u4r
        gi = q1*u2i + q2*u4i
        fr = er + gi
        fi = ei - gr
        yr(k, 1, j) = fr*tw(1, 1) - fi*tw(2, 1)
        yi(k, 1, j) = fr*tw(2, 1) + fi*tw(1, 1)
        fr = er - gi
        fi = ei + gr
        yr(k, 4, j) = fr*tw(1, 4) - fi*tw(2, 4)
        yi(k, 4, j) = fr*tw(2, 4) + fi*tw(1, 4)
        er = xr(k, j, 0) + k2*u1r + k1*u3r     ! b2, b3 = e -+ i g
        ei = xi(k, j, 0) + k2*u1i + k1*u3i
        gr = q2*u2r - q1*u4r
        gi = q2*u2i - q1*u4i
        fr = er + gi
        fi = ei - gr
        yr(k, 2, j) = fr*tw(1, 2) - fi*tw(2, 2)
        yi(k, 2, j) = fr*tw(2, 2) + fi*tw(1, 2)
        fr = er - gi
        fi = ei + gr
        yr(k, 3, j) = fr*tw(1, 3) - fi*tw(2, 3)
        yi(k, 3, j) = fr*tw(2, 3) + fi*tw(1, 3)
      end do
    end do
  end subroutine stage5

  !> The transforms X, Y (f = 0 .. n/2) of two real series x, y (zero-
  !> padded to n = p%n) by one complex transform of x + i y.
  subroutine fft_real_pair(p, x, y, xf, yf, ok)
    type(fft_plan_t), intent(in) :: p
    real(wp), intent(in) :: x(:), y(:)
    complex(wp), intent(out) :: xf(0:), yf(0:)
    logical, intent(out) :: ok          !< false when the workspace did not fit in memory
    real(wp) :: fr(0:p%n/2, 2), fi(0:p%n/2, 2), xy(2, size(x))
    xy(1, :) = x
    xy(2, :) = y
    ok = .true.
    call real_block(p, xy, 1, 2, fr, fi, ok)
    xf(0:p%n/2) = cmplx(fr(:, 1), fi(:, 1), wp)
    yf(0:p%n/2) = cmplx(fr(:, 2), fi(:, 2), wp)
  end subroutine fft_real_pair

  !> The transforms fr + i fi (f = 0 .. n/2, one column each) of the rows of
  !> x (real series of at most n samples, zero-padded to n = p%n), two to a
  !> complex transform z = x1 + i x2: X1(f) = (Z(f) + conj(Z(n-f)))/2,
  !> X2(f) = (Z(f) - conj(Z(n-f)))/(2i); BLOCK complex series at a time,
  !> the blocks fixed by the rows alone (the result does not depend on the
  !> threads).
  subroutine fft_real_many(p, x, fr, fi, ok)
    type(fft_plan_t), intent(in) :: p
    real(wp), contiguous, intent(in) :: x(:, :)
    real(wp), intent(out) :: fr(0:p%n/2, size(x, 1)), fi(0:p%n/2, size(x, 1))
    logical, intent(out) :: ok          !< false when a block's workspace did not fit in memory
    integer :: r0, nr
    ok = .true.
    !$omp parallel do private(nr) schedule(static) reduction(.and.:ok)
    do r0 = 1, size(x, 1), 2*BLOCK
      nr = min(2*BLOCK, size(x, 1) - r0 + 1)
      call real_block(p, x, r0, nr, fr(:, r0:r0 + nr - 1), fi(:, r0:r0 + nr - 1), ok)
    end do
    !$omp end parallel do
  end subroutine fft_real_many

  !> fft_real_many on the rows r0 .. r0 + nr - 1 of x: the first half of
  !> them in the real parts, the rest in the imaginary parts.  (The block's
  !> rows are picked by explicit loops: as an array section they cost
  !> several times the copy.)
  subroutine real_block(p, x, r0, nr, fr, fi, ok)
    type(fft_plan_t), intent(in) :: p
    real(wp), contiguous, intent(in) :: x(:, :)
    integer, intent(in) :: r0, nr
    real(wp), intent(out) :: fr(0:, :), fi(0:, :)
    logical, intent(inout) :: ok        !< set false when the workspace does not fit
    real(wp), allocatable :: zr(:, :), zi(:, :), yr(:, :), yi(:, :)
    integer :: m, m2, nt, ist
    real(wp) :: down(nr)
    logical :: in_y
    m = (nr + 1)/2
    allocate (zr(m, 0:p%n - 1), zi(m, 0:p%n - 1), yr(m, 0:p%n - 1), yi(m, 0:p%n - 1), stat=ist)
    if (ist /= 0) then
      ok = .false.
      return
    end if
    m2 = nr - m
    nt = size(x, 2)
    ! each series scaled by a power of two to a largest value near 1 (exact):
    ! a transform's rounding is relative to its largest values, and a pair's
    ! two series may differ in size by orders of magnitude
    if (nr == 2*BLOCK) then                   ! the usual block: its loops at a fixed length
      call scaled_rows(2*BLOCK, BLOCK, x, r0, down, zr, zi)
    else
      call scaled_rows(nr, m, x, r0, down, zr, zi)
    end if
    zr(:, nt:) = 0.0_wp                       ! the zero padding
    if (m2 < m) zi(m, 0:nt - 1) = 0.0_wp
    zi(:, nt:) = 0.0_wp
    call stages(p, m, zr, zi, yr, yi, in_y)
    if (in_y) then
      call unpack(p%n, m2, yr, yi, down, fr, fi)
    else
      call unpack(p%n, m2, zr, zi, down, fr, fi)
    end if
  end subroutine real_block

  !> down(j) = the power of two that scales row r0 - 1 + j of x to a
  !> largest value near 1 (j = 1 .. nr), and the rows so scaled: the first
  !> m in zr, the rest in zi (columns 0 .. nt - 1).
  pure subroutine scaled_rows(nr, m, x, r0, down, zr, zi)
    integer, intent(in) :: nr, m, r0
    real(wp), contiguous, intent(in) :: x(:, :)
    real(wp), intent(out) :: down(nr)
    real(wp), intent(inout) :: zr(:, 0:), zi(:, 0:)
    integer :: t, j
    down = 0.0_wp
    do t = 1, size(x, 2)                      ! the rows' largest values, column by column
      do j = 1, nr
        down(j) = max(down(j), abs(x(r0 - 1 + j, t)))
      end do
    end do
    do j = 1, nr
      down(j) = scale(1.0_wp, -exponent(down(j)))
    end do
    do t = 1, size(x, 2)
      do j = 1, m
        zr(j, t - 1) = down(j)*x(r0 - 1 + j, t)
      end do
      do j = 1, nr - m
        zi(j, t - 1) = down(m + j)*x(r0 - 1 + m + j, t)
      end do
    end do
  end subroutine scaled_rows

  !> The real series' transforms from z = x1 + i x2 (m series, the first m2
  !> with a second one), f = 0 .. n/2, each series' scaling down undone:
  !> series by series (its frequencies written in turn), both of a pair
  !> from one pass over z.
  pure subroutine unpack(n, m2, zr, zi, down, fr, fi)
    integer, intent(in) :: n, m2
    real(wp), intent(in) :: zr(:, 0:), zi(:, 0:), down(:)
    real(wp), intent(out) :: fr(0:, :), fi(0:, :)
    real(wp) :: h, h2
    integer :: f, j, m
    m = size(zr, 1)
    do j = 1, m2
      h = 0.5_wp/down(j)
      h2 = 0.5_wp/down(m + j)
      fr(0, j) = (zr(j, 0) + zr(j, 0))*h     ! f = 0: its partner n - f is itself
      fi(0, j) = (zi(j, 0) - zi(j, 0))*h
      fr(0, m + j) = (zi(j, 0) + zi(j, 0))*h2
      fi(0, m + j) = (zr(j, 0) - zr(j, 0))*h2
      do f = 1, n/2
        fr(f, j) = (zr(j, f) + zr(j, n - f))*h
        fi(f, j) = (zi(j, f) - zi(j, n - f))*h
        fr(f, m + j) = (zi(j, f) + zi(j, n - f))*h2
        fi(f, m + j) = (zr(j, n - f) - zr(j, f))*h2
      end do
    end do
    do j = m2 + 1, m
      h = 0.5_wp/down(j)
      fr(0, j) = (zr(j, 0) + zr(j, 0))*h
      fi(0, j) = (zi(j, 0) - zi(j, 0))*h
      do f = 1, n/2
        fr(f, j) = (zr(j, f) + zr(j, n - f))*h
        fi(f, j) = (zi(j, f) - zi(j, n - f))*h
      end do
    end do
  end subroutine unpack

  !> z = DFT(z) (inverse: unnormalised, exp(+...)) of any length: the FFT
  !> when the length is 2^a 3^b 5^c, else Bluestein's chirp-z.  ok false
  !> when its workspace did not fit in memory.
  subroutine fft_any_length(z, inverse, ok)
    complex(wp), intent(inout) :: z(0:)
    logical, intent(in) :: inverse
    logical, intent(out) :: ok
    type(fft_plan_t) :: plan
    complex(wp), allocatable :: a(:), b(:), c(:)
    integer :: m, l, j, ist
    integer(kind=8) :: j2
    real(wp), parameter :: PI = 4.0_wp*atan(1.0_wp)
    m = size(z)
    ok = .true.
    if (inverse) z = conjg(z)
    if (fft_smooth_length(m) == m) then
      plan = fft_plan(m)
      call fft_forward(plan, z)
    else
      l = fft_smooth_length(2*m - 1)
      allocate (a(0:l - 1), b(0:l - 1), c(0:m - 1), stat=ist)
      ok = ist == 0
      if (.not. ok) return
      do j = 0, m - 1                        ! c(j) = exp(-i pi j^2/m), j^2 taken mod 2m
        j2 = mod(int(j, 8)*j, 2_8*m)
        c(j) = cmplx(cos(PI*j2/m), -sin(PI*j2/m), wp)
      end do
      a = 0.0_wp
      a(0:m - 1) = z*c
      b = 0.0_wp
      b(0:m - 1) = conjg(c)
      do j = 1, m - 1
        b(l - j) = conjg(c(j))
      end do
      plan = fft_plan(l)
      call fft_forward(plan, a)
      call fft_forward(plan, b)
      a = conjg(a*b)                         ! the convolution by an inverse transform
      call fft_forward(plan, a)
      z = c*conjg(a(0:m - 1))/l
    end if
    if (inverse) z = conjg(z)
  end subroutine fft_any_length

end module mlid_fft
