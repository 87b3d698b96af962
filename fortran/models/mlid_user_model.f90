!> A user's own model: the template to copy, with one worked example.
!>
!> mlid was used, like the original program, by writing the aircraft
!> equations and letting the program do the rest.  To bring your own model:
!>
!>   1. Edit this file (keep the module and type names): set the sizes in
!>      user_model_create, and write um_eval: f and h, and their Jacobians
!>      with respect to x and to the parameters p, at one point.  It is
!>      asked for any of them at once (present arguments): compute what they
!>      share once (here the state equations, which the output qdot reuses),
!>      fill those present, never touch the absent ones.  Constants come in
!>      through iconst/rconst.  Keep um_eval's argument declarations as they
!>      are: they are the model interface's (mlid_models' eval_iface).
!>   2. Rebuild (make test, or pip install .): the model is then in both the
!>      Python extension and mlid-batch, as kind = 'user' in a deck or
!>      mlid.UserModel in Python.
!>   3. Check the Jacobians: mlid.check_jacobians(model, x, u) compares them
!>      with central differences (tests/test_user_model.py does it for this
!>      example); an error in a Jacobian makes the fit converge slowly or to
!>      the wrong place and the Cramer-Rao bounds wrong.
!>
!> Worked example: a short-period model with a cubic pitching moment,
!> for large-amplitude manoeuvres where C_m(alpha) bends,
!>
!>   alphadot = Z_a alpha + q + Z_d de
!>   qdot     = M_a alpha + M_a3 alpha^3 + M_q q + M_d de
!>   outputs  alpha, q, qdot
!>
!> p = [Z_a, Z_d, M_a, M_a3, M_q, M_d]; no constants.
module mlid_user_model
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t
  implicit none
  private
  public :: user_model_t, user_model_create

  type, extends(model_t) :: user_model_t
  contains
    procedure :: eval => um_eval
    procedure :: dfdw => um_dfdw
    procedure :: dhdxp => um_dhdxp
  end type user_model_t

contains

  !> Sizes and constants.  Report bad constants through status and msg;
  !> never stop.
  subroutine user_model_create(iconst, rconst, m, status, msg)
    integer, intent(in) :: iconst(:)
    real(wp), intent(in) :: rconst(:)
    type(user_model_t), intent(out) :: m
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    if (size(iconst) /= 0 .or. size(rconst) /= 0) then
      status = MLID_ERR_INPUT
      msg = 'user model (cubic short period): takes no constants'
      return
    end if
    m%nx = 2      ! alpha, q
    m%nu = 1      ! delta_e
    m%ny = 3      ! alpha, q, qdot
    m%nw = 0      ! no process-noise inputs
    m%np = 6      ! Z_a, Z_d, M_a, M_a3, M_q, M_d
    status = MLID_OK
    msg = ''
  end subroutine user_model_create

  !> The model at (t, x, u): each argument present, of
  !>   xdot = f,  a(i, j) = d f_i/d x_j,  b(i, k) = d f_i/d p(idx(k)),
  !>   y = h,     c(i, j) = d h_i/d x_j,  d(i, k) = d h_i/d p(idx(k)).
  !> u may carry process noise after the inputs (none here).
  pure subroutine um_eval(self, t, x, u, p, idx, xdot, a, b, y, c, d)
    class(user_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(self%nx), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out), optional :: xdot(self%nx), a(self%nx, self%nx), b(self%nx, size(idx)), &
                                       y(self%ny), c(self%ny, self%nx), d(self%ny, size(idx))
    real(wp) :: fx(2), fa(2, 2), fb(2, 6)      ! f, df/dx and df/dp for all of p

    ! What f and h share, once: the state equations and their Jacobians.
    fx(1) = p(1)*x(1) + x(2) + p(2)*u(1)
    fx(2) = p(3)*x(1) + p(4)*x(1)**3 + p(5)*x(2) + p(6)*u(1)
    fa(1, :) = [p(1), 1.0_wp]
    fa(2, :) = [p(3) + 3.0_wp*p(4)*x(1)**2, p(5)]
    fb = 0.0_wp
    fb(1, 1:2) = [x(1), u(1)]
    fb(2, 3:6) = [x(1), x(1)**3, x(2), u(1)]

    if (present(xdot)) xdot = fx
    if (present(a)) a = fa
    if (present(b)) b = fb(:, idx)               ! only the requested parameters
    ! Outputs alpha, q, qdot: qdot is the second state equation.
    if (present(y)) y = [x(1), x(2), fx(2)]
    if (present(c)) then
      c = 0.0_wp
      c(1, 1) = 1.0_wp
      c(2, 2) = 1.0_wp
      c(3, :) = fa(2, :)
    end if
    if (present(d)) then
      d = 0.0_wp
      d(3, :) = fb(2, idx)
    end if
  end subroutine um_eval

  !> How process noise enters (none here: nw = 0).
  pure subroutine um_dfdw(self, t, x, u, p, g)
    class(user_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: g(:, :)
    g = 0.0_wp
  end subroutine um_dfdw

  !> d(dh/dx)/dp, used by the Kalman filter's partials (linear models only for now).
  pure subroutine um_dhdxp(self, t, x, u, p, idx, dc)
    class(user_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: dc(:, :, :)
    dc = 0.0_wp
  end subroutine um_dhdxp

end module mlid_user_model
