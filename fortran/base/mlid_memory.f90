!> Allocations that may not fit in memory (arrays the length of a record):
!> allocated with stat=, and a failure becomes the status MLID_ERR_MEMORY
!> (its message built only then: a fit allocates in every evaluation)
!> with a message naming what did not fit and its size, in place of the
!> Fortran runtime's abort (which ends the Python interpreter too).
module mlid_memory
  use mlid_kinds, only: wp, MLID_ERR_MEMORY
  implicit none
  private
  public :: no_memory

contains

  !> status MLID_ERR_MEMORY and msg 'not enough memory for <what> (<size>)',
  !> the size that of nreal reals (8 bytes each).
  subroutine no_memory(what, nreal, status, msg)
    character(len=*), intent(in) :: what
    real(wp), intent(in) :: nreal
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=16) :: size
    real(wp) :: bytes
    bytes = 8.0_wp*nreal
    if (bytes >= 1.0e9_wp) then
      write (size, '(f0.1,a)') bytes/1.0e9_wp, ' GB'
    else
      write (size, '(f0.1,a)') bytes/1.0e6_wp, ' MB'
    end if
    status = MLID_ERR_MEMORY
    msg = 'not enough memory for '//what//' ('//trim(size)//')'
  end subroutine no_memory

end module mlid_memory
