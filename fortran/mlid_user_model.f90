!> A user's own model: the template to copy, with one worked example.
!>
!> mlid was used, like the original program, by writing the aircraft
!> equations and letting the program do the rest.  To bring your own model:
!>
!>   1. Edit this file (keep the module and type names): set the sizes in
!>      user_model_create, write f and h, and their Jacobians with respect to
!>      x and to the parameters p.  Constants come in through iconst/rconst.
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
    procedure :: f => um_f
    procedure :: h => um_h
    procedure :: dfdx => um_dfdx
    procedure :: dfdp => um_dfdp
    procedure :: dhdx => um_dhdx
    procedure :: dhdp => um_dhdp
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

  pure subroutine um_f(self, t, x, u, p, xdot)
    class(user_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: xdot(:)
    xdot(1) = p(1)*x(1) + x(2) + p(2)*u(1)
    xdot(2) = p(3)*x(1) + p(4)*x(1)**3 + p(5)*x(2) + p(6)*u(1)
  end subroutine um_f

  pure subroutine um_h(self, t, x, u, p, y)
    class(user_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: y(:)
    real(wp) :: xdot(2)
    call um_f(self, t, x, u, p, xdot)
    y = [x(1), x(2), xdot(2)]
  end subroutine um_h

  !> a(i, j) = d f_i / d x_j
  pure subroutine um_dfdx(self, t, x, u, p, a)
    class(user_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: a(:, :)
    a(1, :) = [p(1), 1.0_wp]
    a(2, :) = [p(3) + 3.0_wp*p(4)*x(1)**2, p(5)]
  end subroutine um_dfdx

  !> b(i, k) = d f_i / d p(idx(k)): only the requested parameters.
  pure subroutine um_dfdp(self, t, x, u, p, idx, b)
    class(user_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: b(:, :)
    real(wp) :: full(2, 6)
    full = 0.0_wp
    full(1, 1:2) = [x(1), u(1)]
    full(2, 3:6) = [x(1), x(1)**3, x(2), u(1)]
    b = full(:, idx)
  end subroutine um_dfdp

  pure subroutine um_dhdx(self, t, x, u, p, c)
    class(user_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: c(:, :)
    real(wp) :: a(2, 2)
    call um_dfdx(self, t, x, u, p, a)
    c = 0.0_wp
    c(1, 1) = 1.0_wp
    c(2, 2) = 1.0_wp
    c(3, :) = a(2, :)
  end subroutine um_dhdx

  pure subroutine um_dhdp(self, t, x, u, p, idx, d)
    class(user_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: d(:, :)
    real(wp) :: b(2, size(idx))
    call um_dfdp(self, t, x, u, p, idx, b)
    d = 0.0_wp
    d(3, :) = b(2, :)
  end subroutine um_dhdp

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
