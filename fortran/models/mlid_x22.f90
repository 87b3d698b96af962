!> X-22 VTOL longitudinal model of report Appendix A (§5.1).
!>
!> States x = (u, w, theta, q) [ft/s, ft/s, rad, rad/s], total body
!> velocities; input delta_es; process noise v = (v1, v2, v3), gusts in u, w
!> [ft/s] and q [rad/s].  The aerodynamic accelerations are polynomials in u,
!>
!>   A_X = X_o(u) + X_w(u) w + X_d(u) delta
!>   A_Z = Z_o(u) + Z_w(u) w + Z_d(u) delta
!>   A_M = M_o(u) + M_w(u) w + M_q(u) q + M_d(u) delta
!>
!> with X_o, Z_o, M_o of second order and the others of first (23
!> coefficients), and the gusts enter through g(x, p) = dA/d(u, w, q) (the
!> first-order change of A at the gust-disturbed velocities):
!>
!>   udot     = A_X - q w - g sin theta + A_X,u v1 + A_X,w v2
!>   wdot     = A_Z + q u + g cos theta + A_Z,u v1 + A_Z,w v2
!>   thetadot = q
!>   qdot     = A_M + A_M,u v1 + A_M,w v2 + A_M,q v3
!>
!> Outputs y = (u, w, theta, q, qdot, n_x, n_z) with the accelerometers
!> n_x = (udot + q w)/g + sin theta = (A_X + noise)/g and n_z = (A_Z +
!> noise)/g [g units]: qdot, n_x and n_z carry the process noise (dh/dw, the
!> correlated case of §5.1.7).  h itself gives the outputs without it.
!>
!> Since every term is a coefficient times a regressor, f is linear in p:
!> coefficient k multiplies r_k = phi_k(u) s_k + its gust change, where
!> phi_k is 1, u or u^2 and s_k is 1, w, q or delta.  The parameter order
!> p = [M_o(3), M_w(2), M_q(2), M_d(2), X_o(3), X_w(2), X_d(2), Z_o(3),
!> Z_w(2), Z_d(2)], each polynomial by rising power of u.  No constants.
module mlid_x22
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t
  implicit none
  private
  public :: x22_t, x22_create, X22_LABELS

  real(wp), parameter :: G0 = 32.174_wp       !< gravity, ft/s^2
  integer, parameter :: NPX = 23
  !> state equation each coefficient enters (1 = udot, 2 = wdot, 4 = qdot),
  !> power of u, and what it multiplies (1 one, 2 w, 3 q, 4 delta)
  integer, parameter :: ROW(NPX) = [4, 4, 4, 4, 4, 4, 4, 4, 4, 1, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2]
  integer, parameter :: POW(NPX) = [0, 1, 2, 0, 1, 0, 1, 0, 1, 0, 1, 2, 0, 1, 0, 1, 0, 1, 2, 0, 1, 0, 1]
  integer, parameter :: SIG(NPX) = [1, 1, 1, 2, 2, 3, 3, 4, 4, 1, 1, 1, 2, 2, 4, 4, 1, 1, 1, 2, 2, 4, 4]

  !> Labels of the coefficients (as mlid.model.X22_LABELS in Python)
  character(len=8), parameter :: X22_LABELS(NPX) = [character(len=8) :: &
    'M_o', 'M_o.u', 'M_o.u2', 'M_w', 'M_w.u', 'M_q', 'M_q.u', 'M_de', 'M_de.u', &
    'X_o', 'X_o.u', 'X_o.u2', 'X_w', 'X_w.u', 'X_de', 'X_de.u', &
    'Z_o', 'Z_o.u', 'Z_o.u2', 'Z_w', 'Z_w.u', 'Z_de', 'Z_de.u']

  type, extends(model_t) :: x22_t
  contains
    procedure :: eval => xeval
    procedure :: dfdw => xdfdw
    procedure :: dhdw => xdhdw
    procedure :: dhdxp => xdhdxp
    procedure :: measured_states => x22_measured_states
  end type x22_t

contains

  !> The outputs u, w, theta, q are the states (output_part, y(1:4) = x).
  pure subroutine x22_measured_states(self, p, which, known)
    class(x22_t), intent(in) :: self
    real(wp), intent(in) :: p(:)
    integer, intent(out) :: which(:)
    logical, intent(out) :: known
    which = [1, 2, 3, 4, 0, 0, 0]
    known = .true.
  end subroutine x22_measured_states

  subroutine x22_create(iconst, rconst, m, status, msg)
    integer, intent(in) :: iconst(:)
    real(wp), intent(in) :: rconst(:)
    type(x22_t), intent(out) :: m
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    if (size(iconst) /= 0 .or. size(rconst) /= 0) then
      status = MLID_ERR_INPUT
      msg = 'X-22 model: takes no constants'
      return
    end if
    m%nx = 4
    m%nu = 1
    m%ny = 7
    m%nw = 3
    m%np = NPX
    status = MLID_OK
    msg = ''
  end subroutine x22_create

  !> Everything about the regressors at (x, u): r(k) with the gust change,
  !> its partials by state (ru, rw, rq) and by gust (rv1, rv2, rv3).
  pure subroutine regressors(x, u, v, r, ru, rw, rq, rv)
    real(wp), intent(in) :: x(:), u(:), v(3)
    real(wp), intent(out) :: r(NPX), ru(NPX), rw(NPX), rq(NPX), rv(NPX, 3)
    real(wp) :: phi(0:2), dphi(0:2), ddphi(0:2), s(4), dsw(4), dsq(4)
    integer :: k

    ! phi = 1, u, u^2 and their u-derivatives; s = 1, w, q, delta and their
    ! w- and q-derivatives (the only states they carry)
    phi = [1.0_wp, x(1), x(1)*x(1)]
    dphi = [0.0_wp, 1.0_wp, 2.0_wp*x(1)]
    ddphi = [0.0_wp, 0.0_wp, 2.0_wp]
    s = [1.0_wp, x(2), x(4), u(1)]
    dsw = [0.0_wp, 1.0_wp, 0.0_wp, 0.0_wp]
    dsq = [0.0_wp, 0.0_wp, 1.0_wp, 0.0_wp]
    do k = 1, NPX
      associate (p0 => phi(POW(k)), p1 => dphi(POW(k)), p2 => ddphi(POW(k)), sk => s(SIG(k)), &
                 sw => dsw(SIG(k)), sq => dsq(SIG(k)))
        ! r = phi s + (phi s)_u v1 + (phi s)_w v2 + (phi s)_q v3
        rv(k, :) = [p1*sk, p0*sw, p0*sq]
        r(k) = p0*sk + rv(k, 1)*v(1) + rv(k, 2)*v(2) + rv(k, 3)*v(3)
        ru(k) = p1*sk + p2*sk*v(1) + p1*(sw*v(2) + sq*v(3))
        rw(k) = (p0 + p1*v(1))*sw
        rq(k) = (p0 + p1*v(1))*sq
      end associate
    end do
  end subroutine regressors

  !> The gusts in [delta; v1; v2; v3], zero when not given.
  pure function gusts(self, u) result(v)
    class(x22_t), intent(in) :: self
    real(wp), intent(in) :: u(:)
    real(wp) :: v(3)
    v = 0.0_wp
    if (size(u) >= self%nu + 3) v = u(self%nu + 1:self%nu + 3)
  end function gusts

  !> The aerodynamic accelerations A_X, A_Z, A_M (with the gust change).
  pure function aero(p, r) result(a)
    real(wp), intent(in) :: p(:), r(NPX)
    real(wp) :: a(3)
    a(1) = sum(p(10:16)*r(10:16))
    a(2) = sum(p(17:23)*r(17:23))
    a(3) = sum(p(1:9)*r(1:9))
  end function aero

  !> The model at one point (model_t%eval): the regressors once (f's at
  !> the gusts u carries, h's without gusts: once more only when the gusts
  !> are not zero), then what is asked for.
  pure subroutine xeval(self, t, x, u, p, idx, xdot, a, b, y, c, d)
    class(x22_t), intent(in) :: self
    real(wp), intent(in) :: t, x(self%nx), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out), optional :: xdot(self%nx), a(self%nx, self%nx), b(self%nx, size(idx)), &
                                       y(self%ny), c(self%ny, self%nx), d(self%ny, size(idx))
    real(wp) :: r(NPX), ru(NPX), rw(NPX), rq(NPX), rv(NPX, 3), v(3)
    logical :: wantf, wanth

    wantf = present(xdot) .or. present(a) .or. present(b)
    wanth = present(y) .or. present(c) .or. present(d)
    v = gusts(self, u)
    if (wantf .or. all(v == 0.0_wp)) then
      call regressors(x, u, v, r, ru, rw, rq, rv)
      if (wantf) call state_part(x, p, idx, r, ru, rw, rq, xdot, a, b)
    end if
    if (.not. wanth) return
    if (any(v /= 0.0_wp)) call regressors(x, u, [0.0_wp, 0.0_wp, 0.0_wp], r, ru, rw, rq, rv)
    call output_part(x, p, idx, r, ru, rw, rq, y, c, d)
  end subroutine xeval

  !> f, df/dx and df/dp(idx), each if present, from the regressors.
  pure subroutine state_part(x, p, idx, r, ru, rw, rq, xdot, a, b)
    real(wp), intent(in) :: x(:), p(:), r(NPX), ru(NPX), rw(NPX), rq(NPX)
    integer, intent(in) :: idx(:)
    real(wp), intent(out), optional :: xdot(:), a(:, :), b(:, :)
    real(wp) :: ae(3)
    integer :: k
    if (present(xdot)) then
      ae = aero(p, r)
      xdot(1) = ae(1) - x(4)*x(2) - G0*sin(x(3))
      xdot(2) = ae(2) + x(4)*x(1) + G0*cos(x(3))
      xdot(3) = x(4)
      xdot(4) = ae(3)
    end if
    if (present(a)) then
      a = 0.0_wp
      a(1, :) = [sum(p(10:16)*ru(10:16)), sum(p(10:16)*rw(10:16)) - x(4), -G0*cos(x(3)), -x(2)]
      a(2, :) = [sum(p(17:23)*ru(17:23)) + x(4), sum(p(17:23)*rw(17:23)), -G0*sin(x(3)), x(1)]
      a(3, 4) = 1.0_wp
      a(4, :) = [sum(p(1:9)*ru(1:9)), sum(p(1:9)*rw(1:9)), 0.0_wp, sum(p(1:9)*rq(1:9))]
    end if
    if (present(b)) then
      b = 0.0_wp
      do k = 1, size(idx)
        b(ROW(idx(k)), k) = r(idx(k))
      end do
    end if
  end subroutine state_part

  !> h, dh/dx and dh/dp(idx), each if present, from the regressors
  !> without gusts.
  pure subroutine output_part(x, p, idx, r, ru, rw, rq, y, c, d)
    real(wp), intent(in) :: x(:), p(:), r(NPX), ru(NPX), rw(NPX), rq(NPX)
    integer, intent(in) :: idx(:)
    real(wp), intent(out), optional :: y(:), c(:, :), d(:, :)
    integer, parameter :: OUT_ROW(4) = [6, 7, 0, 5]     ! udot -> n_x, wdot -> n_z, qdot -> qdot
    real(wp) :: ae(3)
    integer :: k
    if (present(y)) then
      ae = aero(p, r)
      y(1:4) = x(1:4)
      y(5) = ae(3)
      y(6) = ae(1)/G0
      y(7) = ae(2)/G0
    end if
    if (present(c)) then
      c = 0.0_wp
      do k = 1, 4
        c(k, k) = 1.0_wp
      end do
      c(5, :) = [sum(p(1:9)*ru(1:9)), sum(p(1:9)*rw(1:9)), 0.0_wp, sum(p(1:9)*rq(1:9))]
      c(6, :) = [sum(p(10:16)*ru(10:16)), sum(p(10:16)*rw(10:16)), 0.0_wp, 0.0_wp]/G0
      c(7, :) = [sum(p(17:23)*ru(17:23)), sum(p(17:23)*rw(17:23)), 0.0_wp, 0.0_wp]/G0
    end if
    if (present(d)) then
      d = 0.0_wp
      do k = 1, size(idx)            ! the accelerometers are in g units
        d(OUT_ROW(ROW(idx(k))), k) = merge(r(idx(k)), r(idx(k))/G0, ROW(idx(k)) == 4)
      end do
    end if
  end subroutine output_part

  !> g(x, p) of Appendix A: the gust derivatives dA/d(u, w, q).
  pure subroutine xdfdw(self, t, x, u, p, g)
    class(x22_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: g(:, :)
    real(wp) :: r(NPX), ru(NPX), rw(NPX), rq(NPX), rv(NPX, 3)
    integer :: j
    call regressors(x, u, gusts(self, u), r, ru, rw, rq, rv)
    g = 0.0_wp
    do j = 1, 3
      g(1, j) = sum(p(10:16)*rv(10:16, j))
      g(2, j) = sum(p(17:23)*rv(17:23, j))
      g(4, j) = sum(p(1:9)*rv(1:9, j))
    end do
  end subroutine xdfdw

  !> The process noise in qdot, n_x and n_z: g' of §5.1.1.
  pure subroutine xdhdw(self, t, x, u, p, dw)
    class(x22_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: dw(:, :)
    real(wp) :: g(4, 3)
    call xdfdw(self, t, x, u(1:1), p, g)
    dw = 0.0_wp
    dw(5, :) = g(4, :)
    dw(6, :) = g(1, :)/G0
    dw(7, :) = g(2, :)/G0
  end subroutine xdhdw

  pure subroutine xdhdxp(self, t, x, u, p, idx, dc)
    class(x22_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: dc(:, :, :)
    dc = 0.0_wp        ! used by the linear filter's partials only
  end subroutine xdhdxp

end module mlid_x22
