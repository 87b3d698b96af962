!> Nonlinear longitudinal aircraft model whose aerodynamic coefficients
!> are linear in the parameters over named regressors:
!>
!>   C_X = sum_k theta_X,k r_X,k(x, u),  X = D, L, m
!>   Vdot     = -(S/m) qbar C_D + F cos(alpha + sigma)/m + g sin(alpha - theta)
!>   alphadot = -(S/m) qbar/V C_L - F sin(alpha + sigma)/(m V) + q + g cos(alpha - theta)/V
!>   thetadot = q
!>   qdot     = (S cbar/Iy) qbar C_m + (l_T/Iy) F
!>   outputs  V, alpha, theta, q, qdot, a_x, a_z with
!>   a_x = qbar (S/m)(C_L sin alpha - C_D cos alpha) + F cos sigma/m
!>   a_z = qbar (S/m)(-C_L cos alpha - C_D sin alpha) - F sin sigma/m
!>
!> states x = (V, alpha, theta, q), inputs u = (delta_e, F_T), qbar = rho V^2/2.
!> Process noise w (4, variances q, zero unless set) adds to each state
!> equation: atmospheric turbulence for filter error.
!> This is the HFB-320 model of ../shared/data/README.md (Jategaonkar's test
!> case) when the regressors are (1, V/V0, alpha) for C_D and C_L and
!> (1, V/V0, alpha, qhat, delta_e) for C_m, qhat = q cbar/(2 V0).
!>
!> iconst = [nD, nL, nm, codes of C_D's regressors, of C_L's, of C_m's]
!> rconst = [g, S/m, S cbar/Iy, l_T/Iy, V0, m, sigma_T, rho, cbar/2]
!> p = [theta_D, theta_L, theta_m]
module mlid_aero_long
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t
  implicit none
  private
  public :: aero_long_t, aero_long_create, check_longitudinal_record, REGRESSOR_NAMES, NREG, &
            CONSTANT_NAMES

  !> Regressor codes 1..NREG and their names (the deck and Python use the names).
  integer, parameter :: NREG = 6
  character(len=8), parameter :: REGRESSOR_NAMES(NREG) = &
    [character(len=8) :: '1', 'V/V0', 'alpha', 'alpha^2', 'qhat', 'de']
  !> The constants rconst, in order.
  character(len=*), parameter :: CONSTANT_NAMES = 'g, S/m, S cbar/Iy, lT/Iy, V0, m, sigma_T, rho, cbar/2'

  type, extends(model_t) :: aero_long_t
    integer, allocatable :: code(:)      !< regressor code of each parameter
    integer, allocatable :: coef(:)      !< 1 = C_D, 2 = C_L, 3 = C_m for each parameter
    real(wp) :: g = 0, sm = 0, sc = 0, lt = 0, v0 = 0, mass = 0, sigma = 0, rho = 0, c2 = 0
  contains
    procedure :: f => al_f
    procedure :: h => al_h
    procedure :: dfdx => al_dfdx
    procedure :: dfdp => al_dfdp
    procedure :: dhdx => al_dhdx
    procedure :: dhdp => al_dhdp
    procedure :: dfdw => al_dfdw
    procedure :: dhdxp => al_dhdxp
  end type aero_long_t

contains

  subroutine aero_long_create(iconst, rconst, m, status, msg)
    integer, intent(in) :: iconst(:)
    real(wp), intent(in) :: rconst(:)
    type(aero_long_t), intent(out) :: m
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: n(3), np, k

    status = MLID_ERR_INPUT
    if (size(iconst) < 3) then
      msg = 'longitudinal model: iconst must start with the regressor counts of C_D, C_L, C_m'
      return
    end if
    n = iconst(1:3)
    np = sum(n)
    if (any(n < 0) .or. size(iconst) /= 3 + np) then
      msg = 'longitudinal model: iconst must hold 3 counts and then one regressor code per parameter'
      return
    end if
    if (any(iconst(4:) < 1 .or. iconst(4:) > NREG)) then
      msg = 'longitudinal model: unknown regressor code'
      return
    end if
    if (size(rconst) /= 9) then
      write (msg, '(a,i0)') 'longitudinal model: rconst needs 9 constants ('//CONSTANT_NAMES// &
        '), got ', size(rconst)
      return
    end if
    if (.not. (rconst(5) > 0.0_wp .and. rconst(6) > 0.0_wp .and. rconst(8) > 0.0_wp)) then
      msg = 'longitudinal model: V0, mass and density must be > 0'
      return
    end if
    m%nx = 4
    m%nu = 2
    m%ny = 7
    m%nw = 4      ! process noise (turbulence) adds to each state equation
    m%np = np
    m%code = iconst(4:)
    m%coef = [(1, k=1, n(1)), (2, k=1, n(2)), (3, k=1, n(3))]
    m%g = rconst(1)
    m%sm = rconst(2)
    m%sc = rconst(3)
    m%lt = rconst(4)
    m%v0 = rconst(5)
    m%mass = rconst(6)
    m%sigma = rconst(7)
    m%rho = rconst(8)
    m%c2 = rconst(9)
    status = MLID_OK
    msg = ''
  end subroutine aero_long_create

  !> Checks of a record against the model's units: a speed that is not
  !> positive is an error (the equations divide by V); angles or an elevator
  !> beyond 1 rad (57 deg) most likely are degrees: a warning (status OK,
  !> message set).
  subroutine check_longitudinal_record(u, y, status, msg)
    real(wp), intent(in) :: u(:, :), y(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: j
    status = MLID_OK
    msg = ''
    do j = 1, size(y, 2)
      if (.not. y(1, j) > 0.0_wp) then
        status = MLID_ERR_INPUT
        write (msg, '(a,i0,a)') 'data: output 1 (V) must be a positive airspeed in m/s; it is <= 0 '// &
          'at sample ', j, ' (wrong column?)'
        return
      end if
    end do
    if (maxval(abs(y(2:3, :))) > 1.0_wp .or. maxval(abs(u(1, :))) > 1.0_wp) then
      write (msg, '(a,g0.4,a)') 'warning: angles in the data reach ', &
        max(maxval(abs(y(2:3, :))), maxval(abs(u(1, :)))), ': they look like degrees, the '// &
        'longitudinal model expects radians'
    end if
  end subroutine check_longitudinal_record

  !> Regressor values and their derivatives with respect to (V, alpha, q).
  pure subroutine regressor(self, k, x, u, r, dr)
    class(aero_long_t), intent(in) :: self
    integer, intent(in) :: k
    real(wp), intent(in) :: x(:), u(:)
    real(wp), intent(out) :: r, dr(4)
    dr = 0.0_wp
    select case (self%code(k))
    case (1)
      r = 1.0_wp
    case (2)
      r = x(1)/self%v0
      dr(1) = 1.0_wp/self%v0
    case (3)
      r = x(2)
      dr(2) = 1.0_wp
    case (4)
      r = x(2)**2
      dr(2) = 2.0_wp*x(2)
    case (5)
      r = x(4)*self%c2/self%v0
      dr(4) = self%c2/self%v0
    case default
      r = u(1)
    end select
  end subroutine regressor

  !> C_D, C_L, C_m and their gradients with respect to x.
  pure subroutine coefficients(self, x, u, p, c, dc)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: x(:), u(:), p(:)
    real(wp), intent(out) :: c(3), dc(4, 3)
    real(wp) :: r, dr(4)
    integer :: k
    c = 0.0_wp
    dc = 0.0_wp
    do k = 1, self%np
      call regressor(self, k, x, u, r, dr)
      c(self%coef(k)) = c(self%coef(k)) + p(k)*r
      dc(:, self%coef(k)) = dc(:, self%coef(k)) + p(k)*dr
    end do
  end subroutine coefficients

  pure subroutine al_f(self, t, x, u, p, xdot)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: xdot(:)
    real(wp) :: c(3), dc(4, 3), qbar, v, al, th, ft

    call coefficients(self, x, u, p, c, dc)
    v = x(1)
    al = x(2)
    th = x(3)
    ft = u(2)
    qbar = 0.5_wp*self%rho*v*v
    xdot(1) = -self%sm*qbar*c(1) + ft*cos(al + self%sigma)/self%mass + self%g*sin(al - th)
    xdot(2) = -self%sm*qbar/v*c(2) - ft*sin(al + self%sigma)/(self%mass*v) + x(4) &
              + self%g*cos(al - th)/v
    xdot(3) = x(4)
    xdot(4) = self%sc*qbar*c(3) + self%lt*ft
    if (size(u) >= 2 + self%nw) xdot = xdot + u(3:2 + self%nw)   ! process noise, if given
  end subroutine al_f

  pure subroutine al_dfdx(self, t, x, u, p, a)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: a(:, :)
    real(wp) :: c(3), dc(4, 3), qbar, v, al, th, ft, hrv

    call coefficients(self, x, u, p, c, dc)
    v = x(1)
    al = x(2)
    th = x(3)
    ft = u(2)
    qbar = 0.5_wp*self%rho*v*v
    hrv = 0.5_wp*self%rho*v                       ! qbar/V
    a = 0.0_wp
    a(1, :) = -self%sm*qbar*dc(:, 1)
    a(1, 1) = a(1, 1) - self%sm*self%rho*v*c(1)
    a(1, 2) = a(1, 2) - ft*sin(al + self%sigma)/self%mass + self%g*cos(al - th)
    a(1, 3) = a(1, 3) - self%g*cos(al - th)
    a(2, :) = -self%sm*hrv*dc(:, 2)
    a(2, 1) = a(2, 1) - self%sm*0.5_wp*self%rho*c(2) + ft*sin(al + self%sigma)/(self%mass*v*v) &
              - self%g*cos(al - th)/(v*v)
    a(2, 2) = a(2, 2) - ft*cos(al + self%sigma)/(self%mass*v) - self%g*sin(al - th)/v
    a(2, 3) = a(2, 3) + self%g*sin(al - th)/v
    a(2, 4) = a(2, 4) + 1.0_wp
    a(3, 4) = 1.0_wp
    a(4, :) = self%sc*qbar*dc(:, 3)
    a(4, 1) = a(4, 1) + self%sc*self%rho*v*c(3)
  end subroutine al_dfdx

  pure subroutine al_dfdp(self, t, x, u, p, idx, b)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: b(:, :)
    real(wp) :: r, dr(4), qbar
    integer :: k

    qbar = 0.5_wp*self%rho*x(1)**2
    b = 0.0_wp
    do k = 1, size(idx)
      call regressor(self, idx(k), x, u, r, dr)
      select case (self%coef(idx(k)))
      case (1)
        b(1, k) = -self%sm*qbar*r
      case (2)
        b(2, k) = -self%sm*0.5_wp*self%rho*x(1)*r
      case (3)
        b(4, k) = self%sc*qbar*r
      end select
    end do
  end subroutine al_dfdp

  pure subroutine al_h(self, t, x, u, p, y)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: y(:)
    real(wp) :: c(3), dc(4, 3), qbar, xd(4), sa, ca

    call coefficients(self, x, u, p, c, dc)
    call al_f(self, t, x, u, p, xd)
    qbar = 0.5_wp*self%rho*x(1)**2
    sa = sin(x(2))
    ca = cos(x(2))
    y(1:4) = x
    y(5) = xd(4)
    y(6) = qbar*self%sm*(c(2)*sa - c(1)*ca) + u(2)*cos(self%sigma)/self%mass
    y(7) = qbar*self%sm*(-c(2)*ca - c(1)*sa) - u(2)*sin(self%sigma)/self%mass
  end subroutine al_h

  pure subroutine al_dhdx(self, t, x, u, p, c)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: c(:, :)
    real(wp) :: cf(3), dc(4, 3), qbar, sa, ca, a(4, 4), rv
    integer :: i

    call coefficients(self, x, u, p, cf, dc)
    call al_dfdx(self, t, x, u, p, a)
    qbar = 0.5_wp*self%rho*x(1)**2
    rv = self%rho*x(1)                           ! d qbar / dV
    sa = sin(x(2))
    ca = cos(x(2))
    c = 0.0_wp
    do i = 1, 4
      c(i, i) = 1.0_wp
    end do
    c(5, :) = a(4, :)
    c(6, :) = qbar*self%sm*(dc(:, 2)*sa - dc(:, 1)*ca)
    c(6, 1) = c(6, 1) + rv*self%sm*(cf(2)*sa - cf(1)*ca)
    c(6, 2) = c(6, 2) + qbar*self%sm*(cf(2)*ca + cf(1)*sa)
    c(7, :) = qbar*self%sm*(-dc(:, 2)*ca - dc(:, 1)*sa)
    c(7, 1) = c(7, 1) + rv*self%sm*(-cf(2)*ca - cf(1)*sa)
    c(7, 2) = c(7, 2) + qbar*self%sm*(cf(2)*sa - cf(1)*ca)
  end subroutine al_dhdx

  pure subroutine al_dhdp(self, t, x, u, p, idx, d)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: d(:, :)
    real(wp) :: r, dr(4), qbar, sa, ca
    integer :: k

    qbar = 0.5_wp*self%rho*x(1)**2
    sa = sin(x(2))
    ca = cos(x(2))
    d = 0.0_wp
    do k = 1, size(idx)
      call regressor(self, idx(k), x, u, r, dr)
      select case (self%coef(idx(k)))
      case (1)
        d(6, k) = -qbar*self%sm*ca*r
        d(7, k) = -qbar*self%sm*sa*r
      case (2)
        d(6, k) = qbar*self%sm*sa*r
        d(7, k) = -qbar*self%sm*ca*r
      case (3)
        d(5, k) = self%sc*qbar*r
      end select
    end do
  end subroutine al_dhdp

  pure subroutine al_dfdw(self, t, x, u, p, g)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: g(:, :)
    integer :: k
    g = 0.0_wp
    do k = 1, self%nw
      g(k, k) = 1.0_wp
    end do
  end subroutine al_dfdw

  pure subroutine al_dhdxp(self, t, x, u, p, idx, dc)
    class(aero_long_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: dc(:, :, :)
    dc = 0.0_wp
  end subroutine al_dhdxp

end module mlid_aero_long
