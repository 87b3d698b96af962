!> What a call of the flat interface works on, set part by part by name
!> (mlid_api_problem) and kept in the caller's handle: the model, its
!> parameters, the record, the options, and a fit's a priori values and
!> bounds.  A front end sets a part once and runs any number of calls on
!> it, in place of passing every part to every call.
module mlid_problem
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use mlid_kinds, only: MLID_OK, MLID_ERR_INPUT
  use mlid_params, only: tie_t
  implicit none
  private
  public :: problem_t, problem_needs, PART_MODEL, PART_PARAMS, PART_RECORD, PART_OPTIONS, &
            PART_EXTRAS

  !> The parts, as problem_needs names them.
  integer, parameter :: PART_MODEL = 1, PART_PARAMS = 2, PART_RECORD = 3, PART_OPTIONS = 4, &
                        PART_EXTRAS = 5
  character(len=*), parameter :: PART_NAMES(5) = [character(len=7) :: 'model', 'params', &
                                                  'record', 'options', 'extras']

  type :: problem_t
    logical :: has(5) = .false.
    ! the model: kind (mlid_model_factory), sizes, noise inputs, constants
    integer(c_int) :: mkind = 0, nx = 0, nu = 0, ny = 0, nw = 0
    integer(c_int), allocatable :: iconst(:)
    real(c_double), allocatable :: rconst(:)
    ! the parameters [p, x0, bias, q, r, s] (mlid_models), which are free, their ties
    real(c_double), allocatable :: theta(:)
    integer(c_int), allocatable :: isfree(:)
    type(tie_t) :: tie
    ! the record, one column per sample, and each manoeuvre's first sample
    real(c_double), allocatable :: t(:), u(:, :), y(:, :)
    integer(c_int), allocatable :: segstart(:)
    ! the options (layout in mlid_options)
    integer(c_int) :: iopt(16) = 0
    real(c_double) :: ropt(16) = 0
    ! a fit's extras: a priori values and weight (free x free), and bounds, each
    ! used when its use_* is 1
    integer(c_int) :: use_prior = 0, use_bounds = 0
    real(c_double), allocatable :: prior(:), pweight(:, :), lower(:), upper(:)
  end type problem_t

contains

  !> MLID_OK when p has every part of needs, else which one is missing and
  !> what sets it; and the sizes the parts of needs share agree (a part set
  !> for an earlier call and not needed now is not looked at).
  subroutine problem_needs(p, needs, status, msg)
    type(problem_t), intent(in) :: p
    integer, intent(in) :: needs(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k
    status = MLID_ERR_INPUT
    do k = 1, size(needs)
      if (.not. p%has(needs(k))) then
        msg = 'no '//trim(PART_NAMES(needs(k)))//' set (call mlid_set_'// &
              trim(PART_NAMES(needs(k)))//' first)'
        return
      end if
    end do
    if (any(needs == PART_MODEL) .and. any(needs == PART_RECORD)) then
      if (size(p%u, 1) /= p%nu .or. size(p%y, 1) /= p%ny) then
        write (msg, '(a,i0,a,i0,a,i0,a,i0,a)') 'the record has ', size(p%u, 1), ' inputs and ', &
          size(p%y, 1), ' outputs; the model has ', p%nu, ' and ', p%ny
        return
      end if
    end if
    status = MLID_OK
    msg = ''
  end subroutine problem_needs

end module mlid_problem
