!> The discrete Fourier transform of a power-of-two length:
!> Z(f) = sum_k z(k) exp(-2 pi i f k / n), k, f = 0 .. n-1, by Stockham's
!> radix-2 autosort (decimation in frequency, no bit reversal), many series
!> at once: the series index runs innermost, so each butterfly is one long
!> contiguous loop over all series (and, in the later stages, over the
!> stride) with one twiddle, real and imaginary parts apart.  A plan holds
!> the twiddle factors of one length, so many transforms share them.
module mlid_fft
  use mlid_kinds, only: wp
  implicit none
  private
  public :: fft_plan_t, fft_plan, fft_forward, fft_length, fft_real_pair, fft_many, fft_real_many

  type :: fft_plan_t
    integer :: n = 0
    real(wp), allocatable :: wr(:), wi(:)     !< exp(-2 pi i k / n) = wr + i wi, k < n/2
  end type fft_plan_t

  !> Complex series per block of fft_real_many: a block's two buffers of
  !> 4 BLOCK n reals stay in a core's cache at the lengths of the records.
  integer, parameter :: BLOCK = 8

contains

  !> The smallest power of two not below m.
  pure integer function fft_length(m) result(n)
    integer, intent(in) :: m
    n = 1
    do while (n < m)
      n = 2*n
    end do
  end function fft_length

  !> The plan for length n (a power of two).
  pure function fft_plan(n) result(p)
    integer, intent(in) :: n
    type(fft_plan_t) :: p
    real(wp), parameter :: two_pi = 8.0_wp*atan(1.0_wp)
    integer :: k
    p%n = n
    allocate (p%wr(0:max(n/2, 1) - 1), p%wi(0:max(n/2, 1) - 1))
    do k = 0, size(p%wr) - 1
      p%wr(k) = cos(two_pi*k/n)
      p%wi(k) = -sin(two_pi*k/n)
    end do
    if (n >= 4) p%wr(n/4) = 0.0_wp           ! exactly -i
  end function fft_plan

  !> z = DFT(z), z(0:n-1), n = p%n.
  pure subroutine fft_forward(p, z)
    type(fft_plan_t), intent(in) :: p
    complex(wp), intent(inout) :: z(0:)
    real(wp), allocatable :: zr(:), zi(:)
    zr = real(z(0:p%n - 1), wp)
    zi = aimag(z(0:p%n - 1))
    call fft_many(p, 1, zr, zi)
    z(0:p%n - 1) = cmplx(zr, zi, wp)
  end subroutine fft_forward

  !> The transforms of m complex series in place, series j's sample k at
  !> zr(j, k) + i zi(j, k) (arrays m x n, k = 0 .. n-1): log2 n stages
  !> between z and a buffer, each series' values the same whatever m is.
  pure subroutine fft_many(p, m, zr, zi)
    type(fft_plan_t), intent(in) :: p
    integer, intent(in) :: m
    real(wp), intent(inout) :: zr(m*p%n), zi(m*p%n)
    real(wp), allocatable :: yr(:), yi(:)     ! the buffer (on the heap: long records)
    integer :: s, h
    logical :: in_z
    allocate (yr(m*p%n), yi(m*p%n))
    s = 1                                     ! stride: transforms of n/s points, s of them
    in_z = .true.
    do while (s < p%n)
      h = p%n/(2*s)
      if (in_z) then
        call stage(m*s, h, s, p%wr, p%wi, zr, zi, yr, yi)
      else
        call stage(m*s, h, s, p%wr, p%wi, yr, yi, zr, zi)
      end if
      in_z = .not. in_z
      s = 2*s
    end do
    if (.not. in_z) then
      zr = yr
      zi = yi
    end if
  end subroutine fft_many

  !> One radix-2 stage: x holds 2h blocks of c = m s values, y gets the
  !> sums of blocks j and j + h at 2j and their differences turned by the
  !> twiddle exp(-2 pi i j s / n) at 2j + 1.
  pure subroutine stage(c, h, s, wr, wi, xr, xi, yr, yi)
    integer, intent(in) :: c, h, s
    real(wp), intent(in) :: wr(0:), wi(0:), xr(c, 0:2*h - 1), xi(c, 0:2*h - 1)
    real(wp), intent(out) :: yr(c, 0:1, 0:h - 1), yi(c, 0:1, 0:h - 1)
    real(wp) :: cr, ci, dr, di
    integer :: j, k
    do k = 1, c                               ! j = 0: the twiddle is 1
      yr(k, 0, 0) = xr(k, 0) + xr(k, h)
      yi(k, 0, 0) = xi(k, 0) + xi(k, h)
      yr(k, 1, 0) = xr(k, 0) - xr(k, h)
      yi(k, 1, 0) = xi(k, 0) - xi(k, h)
    end do
    do j = 1, h - 1
      cr = wr(j*s)
      ci = wi(j*s)
      do k = 1, c
        yr(k, 0, j) = xr(k, j) + xr(k, j + h)
        yi(k, 0, j) = xi(k, j) + xi(k, j + h)
        dr = xr(k, j) - xr(k, j + h)
        di = xi(k, j) - xi(k, j + h)
        yr(k, 1, j) = dr*cr - di*ci
        yi(k, 1, j) = dr*ci + di*cr
      end do
    end do
  end subroutine stage

  !> The transforms X, Y (f = 0 .. n/2) of two real series x, y (zero-
  !> padded to n = p%n) by one complex transform of x + i y.
  pure subroutine fft_real_pair(p, x, y, xf, yf)
    type(fft_plan_t), intent(in) :: p
    real(wp), intent(in) :: x(:), y(:)
    complex(wp), intent(out) :: xf(0:), yf(0:)
    real(wp) :: fr(0:p%n/2, 2), fi(0:p%n/2, 2)
    call real_block(p, transpose(reshape([x, y], [size(x), 2])), fr, fi)
    xf(0:p%n/2) = cmplx(fr(:, 1), fi(:, 1), wp)
    yf(0:p%n/2) = cmplx(fr(:, 2), fi(:, 2), wp)
  end subroutine fft_real_pair

  !> The transforms fr + i fi (f = 0 .. n/2, one column each) of the rows of
  !> x (real series of at most n samples, zero-padded to n = p%n), two to a
  !> complex transform z = x1 + i x2: X1(f) = (Z(f) + conj(Z(n-f)))/2,
  !> X2(f) = (Z(f) - conj(Z(n-f)))/(2i); BLOCK complex series at a time,
  !> the blocks fixed by the rows alone (the result does not depend on the
  !> threads).
  subroutine fft_real_many(p, x, fr, fi)
    type(fft_plan_t), intent(in) :: p
    real(wp), intent(in) :: x(:, :)
    real(wp), intent(out) :: fr(0:p%n/2, size(x, 1)), fi(0:p%n/2, size(x, 1))
    integer :: r0, nr
    !$omp parallel do private(nr) schedule(static)
    do r0 = 1, size(x, 1), 2*BLOCK
      nr = min(2*BLOCK, size(x, 1) - r0 + 1)
      call real_block(p, x(r0:r0 + nr - 1, :), fr(:, r0:r0 + nr - 1), fi(:, r0:r0 + nr - 1))
    end do
    !$omp end parallel do
  end subroutine fft_real_many

  !> fft_real_many on one block of rows: the first half of them in the real
  !> parts, the rest in the imaginary parts.
  pure subroutine real_block(p, x, fr, fi)
    type(fft_plan_t), intent(in) :: p
    real(wp), intent(in) :: x(:, :)
    real(wp), intent(out) :: fr(0:, :), fi(0:, :)
    real(wp), allocatable :: zr(:, :), zi(:, :)
    integer :: m, m2, nt, f, g
    m = (size(x, 1) + 1)/2
    allocate (zr(m, 0:p%n - 1), zi(m, 0:p%n - 1))
    m2 = size(x, 1) - m
    nt = size(x, 2)
    zr(:, 0:nt - 1) = x(1:m, :)
    zr(:, nt:) = 0.0_wp                       ! the zero padding
    zi(1:m2, 0:nt - 1) = x(m + 1:, :)
    zi(m2 + 1:, 0:nt - 1) = 0.0_wp
    zi(:, nt:) = 0.0_wp
    call fft_many(p, m, zr, zi)
    do f = 0, p%n/2
      g = mod(p%n - f, p%n)
      fr(f, 1:m) = 0.5_wp*(zr(:, f) + zr(:, g))
      fi(f, 1:m) = 0.5_wp*(zi(:, f) - zi(:, g))
      fr(f, m + 1:) = 0.5_wp*(zi(1:m2, f) + zi(1:m2, g))
      fi(f, m + 1:) = 0.5_wp*(zr(1:m2, g) - zr(1:m2, f))
    end do
  end subroutine real_block

end module mlid_fft
