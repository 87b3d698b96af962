!> Ctrl-C around the calls of the flat interface: python/mlid/_bridge.py
!> arms SIGINT before each call and disarms it after (mlid_interrupt.c:
!> Python's handler is passed the signal as well, and raises
!> KeyboardInterrupt once the interrupted call has returned).
module mlid_api_interrupt
  use mlid_interrupt, only: interrupt_arm, interrupt_disarm
  implicit none
  private
  public :: mlid_interrupt_arm, mlid_interrupt_disarm

contains

  !> A call begins: a SIGINT now interrupts it (and any call running).
  subroutine mlid_interrupt_arm()
    call interrupt_arm(.false.)
  end subroutine mlid_interrupt_arm

  !> The call has ended.
  subroutine mlid_interrupt_disarm()
    call interrupt_disarm()
  end subroutine mlid_interrupt_disarm

end module mlid_api_interrupt
