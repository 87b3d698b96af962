!> The finite Fourier transform of sampled records at chosen frequencies:
!>
!>   X(w) = integral from t0 to t0 + (n-1) dt of x(t) exp(-i w t) dt
!>
!> with x(t) the straight lines between the samples, exactly (to rounding)
!> for that interpolant.  Writing theta = w dt and S(theta) = sum_j x_j
!> exp(-i theta j), j = 0 .. n-1, each interior sample's hat function
!> transforms to W(theta) exp(-i theta j), W = 2 (1 - cos theta)/theta^2,
!> and the two end samples' half hats to A(theta) and conj(A(theta)) (times
!> their phase), A = 1/(i theta) + (1 - exp(-i theta))/theta^2, so
!>
!>   X(w) = dt exp(-i w t0) [W S + (A - W) x_0 + (conj(A) - W) x_{n-1} exp(-i theta (n-1))].
!>
!> S is evaluated at any frequency by Goertzel's second-order recursion
!> (one real multiply-add per sample and channel) in Reinsch's form, whose
!> rounding error does not grow as theta -> 0 or pi: u_j = x_j + 2 cos(theta)
!> u_{j-1} - u_{j-2} rewritten on d_j = u_j -+ u_{j-1}.  Then S = exp(-i
!> theta (n-1)) (u_{n-1} - exp(-i theta) u_{n-2}).
module mlid_fourier
  use mlid_kinds, only: wp
  implicit none
  private
  public :: fourier_transform, fourier_sums, fourier_weights

  !> Below this |theta| the weights come from their Taylor series (the
  !> closed forms lose digits to cancellation).
  real(wp), parameter :: SERIES_BELOW = 0.05_wp
  complex(wp), parameter :: IU = (0.0_wp, 1.0_wp)

contains

  !> xf(c, k) = X_c(w(k)) for the channels c (rows of x, samples along the
  !> columns at t0, t0 + dt, ...).  Frequencies in rad/s, any values.
  pure subroutine fourier_transform(x, dt, t0, w, xf)
    real(wp), intent(in) :: x(:, :), dt, t0, w(:)
    complex(wp), intent(out) :: xf(:, :)
    complex(wp) :: s(size(w), size(x, 1)), a, last
    real(wp) :: wt
    integer :: k, n

    n = size(x, 2)
    call fourier_sums(x, w*dt, s)
    do k = 1, size(w)
      call fourier_weights(w(k)*dt, wt, a)
      last = exp(-IU*w(k)*dt*(n - 1))
      xf(:, k) = dt*exp(-IU*w(k)*t0)*(wt*s(k, :) + (a - wt)*x(:, 1) + (conjg(a) - wt)*x(:, n)*last)
    end do
  end subroutine fourier_transform

  !> s(k, c) = sum_j x(c, j) exp(-i theta(k) (j-1)) (Goertzel, Reinsch's
  !> form), all frequencies together: their recursions are independent, so
  !> the inner loop over them runs in vector lanes.  With sg = +1 (cos
  !> theta >= 0) d_j = u_j - u_{j-1}, lam = 2 cos - 2; with sg = -1 d_j =
  !> u_j + u_{j-1}, lam = 2 cos + 2; both are d = x + lam u + sg d, u = d + sg u.
  pure subroutine fourier_sums(x, theta, s)
    real(wp), intent(in) :: x(:, :), theta(:)
    complex(wp), intent(out) :: s(:, :)
    real(wp) :: u(size(theta), size(x, 1)), d(size(theta), size(x, 1))
    real(wp) :: lam(size(theta)), sg(size(theta)), xv, dd
    integer :: j, c, k, n

    n = size(x, 2)
    where (cos(theta) >= 0.0_wp)
      sg = 1.0_wp
      lam = -4.0_wp*sin(0.5_wp*theta)**2
    elsewhere
      sg = -1.0_wp
      lam = 4.0_wp*cos(0.5_wp*theta)**2
    end where
    u = 0.0_wp
    d = 0.0_wp
    do j = 1, n
      do c = 1, size(x, 1)
        xv = x(c, j)
        do k = 1, size(theta)
          dd = xv + lam(k)*u(k, c) + sg(k)*d(k, c)
          d(k, c) = dd
          u(k, c) = dd + sg(k)*u(k, c)
        end do
      end do
    end do
    do c = 1, size(x, 1)       ! u_{n-2} = sg (u_{n-1} - d_{n-1})
      s(:, c) = exp(-IU*theta*(n - 1))*(u(:, c) - exp(-IU*theta)*sg*(u(:, c) - d(:, c)))
    end do
  end subroutine fourier_sums

  !> The interior weight W(theta) = 2 (1 - cos theta)/theta^2 and the end
  !> weight A(theta) = integral_0^1 (1 - v) exp(-i theta v) dv.
  pure subroutine fourier_weights(theta, w, a)
    real(wp), intent(in) :: theta
    real(wp), intent(out) :: w
    complex(wp), intent(out) :: a
    real(wp) :: t2
    t2 = theta*theta
    if (abs(theta) < SERIES_BELOW) then
      ! W = sum (-1)^m 2 theta^2m/(2m+2)!, A = sum (-i theta)^m/(m! (m+1)(m+2))
      w = 1.0_wp - t2/12.0_wp + t2**2/360.0_wp - t2**3/20160.0_wp + t2**4/1814400.0_wp
      a = cmplx(0.5_wp - t2/24.0_wp + t2**2/720.0_wp - t2**3/40320.0_wp, &
                -theta/6.0_wp + theta*t2/120.0_wp - theta*t2**2/5040.0_wp + &
                theta*t2**3/362880.0_wp, wp)
    else
      w = 2.0_wp*(1.0_wp - cos(theta))/t2
      a = 1.0_wp/(IU*theta) + (1.0_wp - exp(-IU*theta))/t2
    end if
  end subroutine fourier_weights

end module mlid_fourier
