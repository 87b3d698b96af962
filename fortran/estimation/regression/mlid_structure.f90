!> The model-structure methods by name: stepwise forward selection with
!> removals (mlid_stepwise), backward elimination (mlid_stepwise) and
!> multivariate orthogonal functions with PSE (mlid_orthogonal_functions);
!> which partial-F thresholds each uses, and the one dispatch that the
!> deck's job 'stepwise' and the flat interface share.
module mlid_structure
  use mlid_kinds, only: wp, MLID_ERR_INPUT
  use mlid_regression, only: regression_settings_t, regression_t
  use mlid_stepwise, only: stepwise_forward, stepwise_backward
  use mlid_orthogonal_functions, only: orthogonal_functions
  use mlid_text, only: choices
  implicit none
  private
  public :: STRUCTURE_METHODS, uses_f_in, uses_f_out, model_structure

  character(len=8), parameter :: STRUCTURE_METHODS(3) = [character(len=8) :: 'forward', &
                                                         'backward', 'mof']

contains

  !> Whether method enters terms by partial F (F_in): forward selection.
  pure logical function uses_f_in(method)
    character(len=*), intent(in) :: method
    uses_f_in = method == 'forward'
  end function uses_f_in

  !> Whether method removes terms by partial F (F_out): the stepwise ones.
  pure logical function uses_f_out(method)
    character(len=*), intent(in) :: method
    uses_f_out = method == 'forward' .or. method == 'backward'
  end function uses_f_out

  !> The terms of y that method selects from the candidates x (N, m), the
  !> forced ones always in.
  subroutine model_structure(method, x, y, forced, s, r, status, msg)
    character(len=*), intent(in) :: method
    real(wp), intent(in) :: x(:, :), y(:)
    logical, intent(in) :: forced(:)
    type(regression_settings_t), intent(in) :: s
    type(regression_t), intent(out) :: r
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    select case (method)
    case ('forward')
      call stepwise_forward(x, y, forced, s, r, status, msg)
    case ('backward')
      call stepwise_backward(x, y, forced, s, r, status, msg)
    case ('mof')
      call orthogonal_functions(x, y, forced, s, r, status, msg)
    case default
      status = MLID_ERR_INPUT
      msg = 'model structure: method must be '//choices(STRUCTURE_METHODS)//', not '''// &
            method(1:min(len(method), 40))//''''
    end select
  end subroutine model_structure

end module mlid_structure
