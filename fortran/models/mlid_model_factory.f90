!> Builds a model of any kind from the flat description of the interface.
module mlid_model_factory
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t, linear_model_t
  use mlid_aero_long, only: aero_long_t, aero_long_create, AERO_LONG_SIZES
  use mlid_user_model, only: user_model_t, user_model_create
  use mlid_x22, only: x22_t, x22_create
  use mlid_equations, only: equations_t, equations_create
  implicit none
  private
  public :: model_create, kind_code, MODEL_LINEAR, MODEL_AERO_LONG, MODEL_USER, MODEL_X22, &
            MODEL_EQUATIONS, MODEL_KIND_NAMES

  !> Model kinds of the flat interface.
  integer, parameter :: MODEL_LINEAR = 1      !< linear state space (mlid_models)
  integer, parameter :: MODEL_AERO_LONG = 2   !< nonlinear longitudinal aircraft (mlid_aero_long)
  integer, parameter :: MODEL_USER = 3        !< the user's own model (mlid_user_model)
  integer, parameter :: MODEL_X22 = 4         !< X-22 VTOL of report Appendix A (mlid_x22)
  integer, parameter :: MODEL_EQUATIONS = 5   !< equations stated as text (mlid_equations)
  !> Each kind's name (a deck's &model kind, Python's model classes), in
  !> the order of the codes above.
  character(len=12), parameter :: MODEL_KIND_NAMES(5) = [character(len=12) :: 'linear', &
                                                         'longitudinal', 'user', 'x22', 'equations']

contains

  !> The code of the kind called name (MODEL_KIND_NAMES), 0 for none.
  integer function kind_code(name)
    character(len=*), intent(in) :: name
    integer :: k
    kind_code = 0
    do k = 1, size(MODEL_KIND_NAMES)
      if (trim(MODEL_KIND_NAMES(k)) == trim(name)) kind_code = k
    end do
  end function kind_code

  !> Build a model from the flat description of the interface.
  !> iconst and rconst carry model constants (unused by the linear model).
  subroutine model_create(kind, nx, nu, ny, nw, iconst, rconst, model, status, msg)
    integer, intent(in) :: kind, nx, nu, ny, nw
    integer, intent(in) :: iconst(:)
    real(wp), intent(in) :: rconst(:)
    class(model_t), allocatable, intent(out) :: model
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(linear_model_t) :: lin
    type(aero_long_t) :: aero
    type(user_model_t) :: user
    type(x22_t) :: x22
    type(equations_t) :: eqs
    integer :: k

    status = MLID_OK
    msg = ''
    if ((nx < merge(0, 1, kind == MODEL_EQUATIONS) .or. nu < 0 .or. ny < 1 .or. nw < 0) .and. &
        .not. (kind /= MODEL_LINEAR .and. all([nx, nu, ny, nw] == -1))) then
      status = MLID_ERR_INPUT
      write (msg, '(a,4(i0,1x),a)') 'model dimensions nx, nu, ny, nw = ', nx, nu, ny, nw, &
        'must be nx >= 1 (0 for equations), nu >= 0, ny >= 1, nw >= 0'
      return
    end if
    select case (kind)
    case (MODEL_LINEAR)
      lin%nx = nx
      lin%nu = nu
      lin%ny = ny
      lin%nw = nw
      lin%of = 0
      lin%og = nx*nx
      lin%oh = lin%og + nx*nu
      lin%od = lin%oh + ny*nx
      lin%ogam = lin%od + ny*nu
      lin%ok = lin%ogam + nx*nw
      lin%obx = lin%ok + nu*nx
      lin%np = lin%obx + nx
      lin%linear = .true.
      allocate (model, source=lin)
    case (MODEL_AERO_LONG)
      if (any([nx, nu, ny, nw] /= AERO_LONG_SIZES) .and. any([nx, nu, ny, nw] /= -1)) then
        status = MLID_ERR_INPUT
        write (msg, '(a,3(i0,a),i0,a)') 'longitudinal model: nx, nu, ny, nw must be ', &
          (AERO_LONG_SIZES(k), ', ', k=1, 3), AERO_LONG_SIZES(4), ' (V, alpha, theta, q; '// &
          'delta_e, thrust; V, alpha, theta, q, qdot, a_x, a_z)'
        return
      end if
      call aero_long_create(iconst, rconst, aero, status, msg)
      if (status /= MLID_OK) return
      allocate (model, source=aero)
    case (MODEL_USER)
      call user_model_create(iconst, rconst, user, status, msg)
      if (status == MLID_OK) call sizes_agree('user model', user, nx, nu, ny, nw, status, msg)
      if (status /= MLID_OK) return
      allocate (model, source=user)
    case (MODEL_X22)
      if (any([nx, nu, ny, nw] /= [4, 1, 7, 3]) .and. any([nx, nu, ny, nw] /= -1)) then
        status = MLID_ERR_INPUT
        msg = 'X-22 model: nx, nu, ny, nw must be 4, 1, 7, 3 (u, w, theta, q; delta_es; '// &
              'u, w, theta, q, qdot, n_x, n_z; gusts in u, w, q)'
        return
      end if
      call x22_create(iconst, rconst, x22, status, msg)
      if (status /= MLID_OK) return
      allocate (model, source=x22)
    case (MODEL_EQUATIONS)
      call equations_create(iconst, rconst, eqs, status, msg)
      if (status == MLID_OK) call sizes_agree('equations model', eqs, nx, nu, ny, nw, status, msg)
      if (status /= MLID_OK) return
      allocate (model, source=eqs)
    case default
      status = MLID_ERR_INPUT
      write (msg, '(a,i0)') 'unknown model kind ', kind
    end select
  end subroutine model_create

  !> A model whose sizes are its own against the sizes asked (all -1: any).
  subroutine sizes_agree(what, m, nx, nu, ny, nw, status, msg)
    character(len=*), intent(in) :: what
    class(model_t), intent(in) :: m
    integer, intent(in) :: nx, nu, ny, nw
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    status = MLID_OK
    msg = ''
    if (all([nx, nu, ny, nw] == -1) .or. all([m%nx, m%nu, m%ny, m%nw] == [nx, nu, ny, nw])) return
    status = MLID_ERR_INPUT
    write (msg, '(a,4(1x,i0),a,4(1x,i0))') what//': nx, nu, ny, nw are', m%nx, m%nu, m%ny, &
      m%nw, ', not', nx, nu, ny, nw
  end subroutine sizes_agree

end module mlid_model_factory
