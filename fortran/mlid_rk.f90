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
  public :: rk4_step, rk4_interval, input_sens_t

  !> How delayed inputs move the sensitivities: entry k, d u(input(k)) /
  !> d theta(col(k)) at the interval's ends (d0, d1; a tie's scale in it),
  !> linear between them like the inputs.  Forces column col(k) through
  !> df/du(:, input(k)).
  type :: input_sens_t
    integer, allocatable :: input(:), col(:)
    real(wp), allocatable :: d0(:), d1(:)
  end type input_sens_t

contains

  !> Advance x (and s, if given) from t0 to t0+dt.
  !>
  !> s(nx, nf) holds dx/dtheta for the free parameters.  The model
  !> parameters p(idxm(k)) force column colm(k) of the sensitivity equation
  !> through df/dp (several may share a column: ties); the other columns
  !> only propagate through df/dx, plus sforce, a constant forcing of every
  !> column (the filter's held noise estimate).  ua, ub may carry the noise
  !> inputs after the control inputs.
  subroutine rk4_step(m, p, t0, dt, ua, ub, x, idxm, colm, wcol, s, sforce, us, uf)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), t0, dt, ua(:), ub(:)
    real(wp), intent(inout) :: x(:)
    integer, intent(in) :: idxm(:), colm(:)
    real(wp), intent(in) :: wcol(:)            !< weight of each (1, or a tie's scale)
    real(wp), intent(inout), optional :: s(:, :)
    real(wp), intent(in), optional :: sforce(:, :)
    type(input_sens_t), intent(in), optional :: us   !< delayed inputs over the sample interval
    real(wp), intent(in), optional :: uf(2)   !< where the step starts and ends in it (0..1)
    real(wp) :: um(size(ua)), th
    real(wp), dimension(size(x)) :: k1, k2, k3, k4

    th = t0 + 0.5_wp*dt
    um = 0.5_wp*(ua + ub)
    if (present(s)) then
      call step_sens(s, size(s, 2))
    else
      call m%f(t0, x, ua, p, k1)
      call m%f(th, x + 0.5_wp*dt*k1, um, p, k2)
      call m%f(th, x + 0.5_wp*dt*k2, um, p, k3)
      call m%f(t0 + dt, x + dt*k3, ub, p, k4)
    end if
    x = x + (dt/6.0_wp)*(k1 + 2.0_wp*(k2 + k3) + k4)

  contains

    !> The stages with the sensitivities (on the stack: this runs per step).
    subroutine step_sens(s, ns)
      integer, intent(in) :: ns
      real(wp), intent(inout) :: s(:, :)
      real(wp), dimension(size(x), ns) :: s1, s2, s3, s4
      call deriv(t0, x, ua, k1, s, s1, 0.0_wp)
      call deriv(th, x + 0.5_wp*dt*k1, um, k2, s + 0.5_wp*dt*s1, s2, 0.5_wp)
      call deriv(th, x + 0.5_wp*dt*k2, um, k3, s + 0.5_wp*dt*s2, s3, 0.5_wp)
      call deriv(t0 + dt, x + dt*k3, ub, k4, s + dt*s3, s4, 1.0_wp)
      s = s + (dt/6.0_wp)*(s1 + 2.0_wp*(s2 + s3) + s4)
    end subroutine step_sens

    !> xd = f, sd = (df/dx) s + wcol df/dp(idxm) (into columns colm) + sforce
    !> + the delayed inputs' forcing at fraction c of the step.
    subroutine deriv(t, xs, ui, xd, ss, sd, c)
      real(wp), intent(in) :: t, xs(:), ui(:), ss(:, :), c
      real(wp), intent(out) :: xd(:), sd(:, :)
      real(wp) :: a(size(xs), size(xs)), b(size(xs), size(idxm))
      integer :: k

      call m%f_jac(t, xs, ui, p, idxm, xd, a, b)
      sd = matmul(a, ss)
      if (size(idxm) > 0) then
        do k = 1, size(idxm)
          sd(:, colm(k)) = sd(:, colm(k)) + wcol(k)*b(:, k)
        end do
      end if
      if (present(sforce)) sd = sd + sforce
      if (present(us)) call input_forcing(t, xs, ui, c, sd)
    end subroutine deriv

    subroutine input_forcing(t, xs, ui, c, sd)
      real(wp), intent(in) :: t, xs(:), ui(:), c
      real(wp), intent(inout) :: sd(:, :)
      real(wp) :: bu(size(xs), m%nu), a
      integer :: k
      if (size(us%input) == 0) return
      call m%dfdu(t, xs, ui, p, bu)
      a = uf(1) + c*(uf(2) - uf(1))         ! the stage's place in the sample interval
      do k = 1, size(us%input)
        sd(:, us%col(k)) = sd(:, us%col(k)) + bu(:, us%input(k))* &
                           ((1.0_wp - a)*us%d0(k) + a*us%d1(k))
      end do
    end subroutine input_forcing

  end subroutine rk4_step

  !> Integrate over the sample interval [t0, t1] in nsub RK4 steps: the
  !> control inputs linear from u0 to u1 (or held at u0 when hold), the
  !> noise inputs w held throughout.  Arguments after x as in rk4_step.
  subroutine rk4_interval(m, p, t0, t1, u0, u1, w, hold, nsub, x, idxm, colm, wcol, s, sforce, &
                          us)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), t0, t1, u0(:), u1(:), w(:)
    logical, intent(in) :: hold
    integer, intent(in) :: nsub
    real(wp), intent(inout) :: x(:)
    integer, intent(in) :: idxm(:), colm(:)
    real(wp), intent(in) :: wcol(:)
    real(wp), intent(inout), optional :: s(:, :)
    real(wp), intent(in), optional :: sforce(:, :)
    type(input_sens_t), intent(in), optional :: us   !< delayed inputs, at t0 and t1
    real(wp) :: ua(size(u0) + size(w)), ub(size(u0) + size(w)), h, ts, uf(2)
    integer :: isub, nu

    if (size(x) == 0) return         ! no states (a regression): nothing to integrate
    nu = size(u0)
    ua(nu + 1:) = w
    ub(nu + 1:) = w
    h = (t1 - t0)/nsub
    do isub = 1, nsub
      ts = t0 + (isub - 1)*h
      if (hold) then
        ua(1:nu) = u0
        ub(1:nu) = u0
      else
        ua(1:nu) = u0 + (u1 - u0)*(real(isub - 1, wp)/nsub)
        ub(1:nu) = u0 + (u1 - u0)*(real(isub, wp)/nsub)
      end if
      if (present(us)) then          ! the delayed inputs' sensitivities, held or linear
        uf = merge([0.0_wp, 0.0_wp], [real(isub - 1, wp), real(isub, wp)]/nsub, hold)
        call rk4_step(m, p, ts, h, ua, ub, x, idxm, colm, wcol, s, sforce, us, uf)
      else if (present(s)) then
        call rk4_step(m, p, ts, h, ua, ub, x, idxm, colm, wcol, s, sforce)
      else
        call rk4_step(m, p, ts, h, ua, ub, x, idxm, colm, wcol)
      end if
    end do
  end subroutine rk4_interval

end module mlid_rk
