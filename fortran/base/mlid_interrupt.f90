!> Ctrl-C in the core: the long loops (samples of a fit's filter and
!> sensitivities, Newton iterations, Monte Carlo runs, design iterations,
!> frequencies) poll check_interrupt, which turns a SIGINT into the
!> status MLID_ERR_INTERRUPTED, and unwind with it as with any status.
!> The flag and the SIGINT handler are C (mlid_interrupt.c, which says
!> how a front end arms them); nothing here is kept between calls.
module mlid_interrupt
  use, intrinsic :: iso_c_binding, only: c_int
  use mlid_kinds, only: MLID_ERR_INTERRUPTED
  implicit none
  private
  public :: check_interrupt, interrupt_requested, interrupt_arm, interrupt_disarm, POLL_MASK

  !> Sample loops poll when iand(j, POLL_MASK) == 0: every 1024 samples,
  !> a few microseconds of work at the least, so the poll costs nothing
  !> measurable and a Ctrl-C is seen within a millisecond or so.
  integer, parameter :: POLL_MASK = 1023

  interface
    integer(c_int) function c_requested() bind(c, name='mlid_sigint_requested')
      import :: c_int
    end function c_requested
    subroutine c_arm(over_default) bind(c, name='mlid_sigint_arm')
      import :: c_int
      integer(c_int), value :: over_default
    end subroutine c_arm
    subroutine c_disarm() bind(c, name='mlid_sigint_disarm')
    end subroutine c_disarm
  end interface

contains

  !> status MLID_ERR_INTERRUPTED and its message if a SIGINT came during
  !> the calls armed now; status and msg untouched otherwise.
  subroutine check_interrupt(status, msg)
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    if (c_requested() /= 0) then
      status = MLID_ERR_INTERRUPTED
      msg = 'interrupted (Ctrl-C)'
    end if
  end subroutine check_interrupt

  !> Whether a SIGINT came during the calls armed now.
  logical function interrupt_requested()
    interrupt_requested = c_requested() /= 0
  end function interrupt_requested

  !> A call that may be interrupted begins: SIGINT handled (see
  !> mlid_interrupt.c) where a front end has a handler of its own, or also
  !> where it has the default if over_default (mlid-batch).
  subroutine interrupt_arm(over_default)
    logical, intent(in) :: over_default
    call c_arm(merge(1_c_int, 0_c_int, over_default))
  end subroutine interrupt_arm

  !> The call ends: the last one running puts the handler back.
  subroutine interrupt_disarm()
    call c_disarm()
  end subroutine interrupt_disarm

end module mlid_interrupt
