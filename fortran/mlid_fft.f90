!> The discrete Fourier transform of a power-of-two length, in place:
!> Z(f) = sum_k z(k) exp(-2 pi i f k / n), k, f = 0 .. n-1 (iterative
!> radix-2, decimation in time).  A plan holds the bit reversal and the
!> twiddle factors of one length, so many transforms share them.
module mlid_fft
  use mlid_kinds, only: wp
  implicit none
  private
  public :: fft_plan_t, fft_plan, fft_forward, fft_length, fft_real_pair

  type :: fft_plan_t
    integer :: n = 0
    integer, allocatable :: rev(:)            !< bit-reversed index of each k
    complex(wp), allocatable :: w(:)          !< exp(-2 pi i k / n), k < n/2
  end type fft_plan_t

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
    integer :: k, bits, j, r
    p%n = n
    allocate (p%rev(0:n - 1), p%w(0:max(n/2, 1) - 1))
    bits = 0
    do while (2**bits < n)
      bits = bits + 1
    end do
    do k = 0, n - 1
      r = 0
      do j = 0, bits - 1
        if (btest(k, j)) r = ibset(r, bits - 1 - j)
      end do
      p%rev(k) = r
    end do
    do k = 0, size(p%w) - 1
      p%w(k) = cmplx(cos(two_pi*k/n), -sin(two_pi*k/n), wp)
    end do
  end function fft_plan

  !> z = DFT(z), z(0:n-1), n = p%n.
  pure subroutine fft_forward(p, z)
    type(fft_plan_t), intent(in) :: p
    complex(wp), intent(inout) :: z(0:)
    complex(wp) :: t, w
    integer :: k, half, step, start, j
    do k = 0, p%n - 1
      if (p%rev(k) > k) then
        t = z(k)
        z(k) = z(p%rev(k))
        z(p%rev(k)) = t
      end if
    end do
    half = 1
    do while (half < p%n)
      step = p%n/(2*half)                     ! twiddle stride at this stage
      if (half < step) then
        do j = 0, half - 1                    ! one twiddle over all its butterflies
          w = p%w(j*step)
          do start = j, p%n - 1, 2*half
            t = w*z(start + half)
            z(start + half) = z(start) - t
            z(start) = z(start) + t
          end do
        end do
      else                                    ! more twiddles than butterflies each: the
        do start = 0, p%n - 1, 2*half         ! same butterflies, the long loop innermost
          do j = start, start + half - 1
            t = p%w((j - start)*step)*z(j + half)
            z(j + half) = z(j) - t
            z(j) = z(j) + t
          end do
        end do
      end if
      half = 2*half
    end do
  end subroutine fft_forward

  !> The transforms X, Y (f = 0 .. n/2) of two real series x, y (zero-
  !> padded to n = p%n) by one complex transform of x + i y: X(f) = (Z(f) +
  !> conj(Z(n-f)))/2, Y(f) = (Z(f) - conj(Z(n-f)))/(2i).
  pure subroutine fft_real_pair(p, x, y, xf, yf)
    type(fft_plan_t), intent(in) :: p
    real(wp), intent(in) :: x(:), y(:)
    complex(wp), intent(out) :: xf(0:), yf(0:)
    complex(wp) :: z(0:p%n - 1), a, b
    integer :: f
    z(0:size(x) - 1) = cmplx(x, y, wp)
    z(size(x):) = 0.0_wp                      ! the zero padding only
    call fft_forward(p, z)
    do f = 0, p%n/2
      a = z(f)
      b = conjg(z(mod(p%n - f, p%n)))
      xf(f) = 0.5_wp*(a + b)
      yf(f) = cmplx(0.0_wp, -0.5_wp, wp)*(a - b)
    end do
  end subroutine fft_real_pair

end module mlid_fft
