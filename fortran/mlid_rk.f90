!> Fourth-order Runge-Kutta integration of the state together with its
!> sensitivities dx/dtheta (report eq. 4.35 with zero gain).
!>
!> The input is linear between the samples: u(k) at the start of a step,
!> (u(k)+u(k+1))/2 at the two mid-step stages, u(k+1) at the end (or u(k)
!> throughout with a zero-order hold, chosen by the caller).
module mlid_rk
  use mlid_kinds, only: wp
  use mlid_models, only: model_t
  implicit none
  private
  public :: rk4_step

contains

  !> Advance x (and s, if given) from t0 to t0+dt.
  !>
  !> s(nx, nf) holds dx/dtheta for the free parameters; its first size(idxm)
  !> columns belong to the model parameters p(idxm), which force the
  !> sensitivity equation through df/dp.  The other columns (initial states,
  !> biases) only propagate through df/dx.
  subroutine rk4_step(m, p, t0, dt, ua, ub, x, idxm, s)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), t0, dt, ua(:), ub(:)
    real(wp), intent(inout) :: x(:)
    integer, intent(in) :: idxm(:)
    real(wp), intent(inout), optional :: s(:, :)
    real(wp) :: um(size(ua)), th
    real(wp), dimension(size(x)) :: k1, k2, k3, k4
    real(wp), allocatable :: s1(:, :), s2(:, :), s3(:, :), s4(:, :)

    th = t0 + 0.5_wp*dt
    um = 0.5_wp*(ua + ub)
    if (present(s)) then
      allocate (s1, s2, s3, s4, mold=s)
      call deriv(t0, x, ua, k1, s, s1)
      call deriv(th, x + 0.5_wp*dt*k1, um, k2, s + 0.5_wp*dt*s1, s2)
      call deriv(th, x + 0.5_wp*dt*k2, um, k3, s + 0.5_wp*dt*s2, s3)
      call deriv(t0 + dt, x + dt*k3, ub, k4, s + dt*s3, s4)
      s = s + (dt/6.0_wp)*(s1 + 2.0_wp*(s2 + s3) + s4)
    else
      call m%f(t0, x, ua, p, k1)
      call m%f(th, x + 0.5_wp*dt*k1, um, p, k2)
      call m%f(th, x + 0.5_wp*dt*k2, um, p, k3)
      call m%f(t0 + dt, x + dt*k3, ub, p, k4)
    end if
    x = x + (dt/6.0_wp)*(k1 + 2.0_wp*(k2 + k3) + k4)

  contains

    !> xd = f, sd = (df/dx) s + [df/dp(idxm), 0].
    subroutine deriv(t, xs, us, xd, ss, sd)
      real(wp), intent(in) :: t, xs(:), us(:), ss(:, :)
      real(wp), intent(out) :: xd(:), sd(:, :)
      real(wp) :: a(size(xs), size(xs)), b(size(xs), size(idxm))
      integer :: nm

      nm = size(idxm)
      call m%f(t, xs, us, p, xd)
      call m%dfdx(t, xs, us, p, a)
      sd = matmul(a, ss)
      if (nm > 0) then
        call m%dfdp(t, xs, us, p, idxm, b)
        sd(:, 1:nm) = sd(:, 1:nm) + b
      end if
    end subroutine deriv

  end subroutine rk4_step

end module mlid_rk
