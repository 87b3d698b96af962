!> Handles: what a caller of the flat interface holds between calls, in
!> place of module variables, so that two threads with two handles never
!> see each other's work.  A handle is the address of a session_t the core
!> allocated (handle_new), given back as an integer; the session holds a
!> deck's cases, each case by name, what running each gave, the channels
!> last read, and the problem a call runs on and what the last call gave.
!> The caller frees it (handle_free) and never uses it after: the check of
!> a handle refuses 0 and a session freed but not yet reused; any other
!> value must be one handle_new gave (Python's _bridge.Handle owns each
!> one, so no other value reaches the core).
module mlid_handles
  use, intrinsic :: iso_c_binding, only: c_ptr, c_loc, c_f_pointer, c_int64_t, c_null_ptr, &
                                         c_associated
  use mlid_kinds, only: MLID_OK, MLID_ERR_INPUT, MLID_ERR_INTERNAL
  use mlid_case, only: case_t
  use mlid_channels, only: channel_set_t
  use mlid_run, only: case_run_t
  use mlid_named, only: named_t
  use mlid_problem, only: problem_t
  use mlid_progress, only: progress_t
  implicit none
  private
  public :: session_t, handle_new, handle_session, call_session, handle_free

  !> Marks a live session: a handle that does not point at one is refused.
  integer(c_int64_t), parameter :: LIVE = int(z'6d6c6964', c_int64_t)

  type :: session_t
    integer(c_int64_t) :: mark = LIVE
    type(case_t), allocatable :: cases(:)        !< the deck read into it
    type(named_t), allocatable :: values(:)      !< each case by name (mlid_case's case_values)
    type(case_run_t), allocatable :: runs(:)     !< what running each case gave
    type(channel_set_t) :: taken                 !< the channels last read or taken
    type(problem_t) :: problem                   !< what the calls run on (mlid_api_problem)
    type(named_t) :: given                       !< a call's other values (mlid_api_values)
    type(named_t) :: results                     !< what the last call gave, by name
    !> the long work of a call given this handle for it, read from another
    !> thread while it runs (mlid_api_deck's mlid_progress_get)
    type(progress_t) :: progress
  end type session_t

contains

  !> A new, empty session; 0 with status set when memory runs out.
  subroutine handle_new(h, status, msg)
    integer(c_int64_t), intent(out) :: h
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(session_t), pointer :: s
    integer :: stat

    h = 0
    status = MLID_OK
    msg = ''
    allocate (s, stat=stat)
    if (stat /= 0) then
      status = MLID_ERR_INTERNAL
      msg = 'out of memory for a new handle'
      return
    end if
    h = transfer(c_loc(s), h)
  end subroutine handle_new

  !> The session of handle h, or null with a message for a handle that is
  !> none (0, or freed).
  subroutine handle_session(h, s, status, msg)
    integer(c_int64_t), intent(in) :: h
    type(session_t), pointer, intent(out) :: s
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(c_ptr) :: p

    s => null()
    status = MLID_ERR_INPUT
    msg = 'not a live handle'
    if (h == 0) return
    p = transfer(h, c_null_ptr)
    if (.not. c_associated(p)) return
    call c_f_pointer(p, s)
    if (s%mark /= LIVE) then
      s => null()
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine handle_session

  !> The session of h for a new call of the flat interface: what the last
  !> call gave is forgotten, so that a call that stops early leaves nothing
  !> of another's to read.
  subroutine call_session(h, s, status, msg)
    integer(c_int64_t), intent(in) :: h
    type(session_t), pointer, intent(out) :: s
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    call handle_session(h, s, status, msg)
    if (status == MLID_OK) s%results = named_t()
  end subroutine call_session

  !> Free the session of h (nothing for 0); h is 0 after.
  subroutine handle_free(h)
    integer(c_int64_t), intent(inout) :: h
    type(session_t), pointer :: s
    integer :: status
    character(len=64) :: msg
    call handle_session(h, s, status, msg)
    if (status == MLID_OK) then
      s%mark = 0
      deallocate (s)
    end if
    h = 0
  end subroutine handle_free

end module mlid_handles
