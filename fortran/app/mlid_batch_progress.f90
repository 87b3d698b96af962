!> mlid-batch's progress line for the long work of a case (mlid_progress:
!> a Monte Carlo's runs, a fit's iterations, a text record's rows): on stderr when it is a
!> terminal, redrawn in place ("\r monte carlo 45%") as often as the core
!> calls tell (at most every 100 ms, from half a second of work on), and
!> ended by a newline when the work ends.  Nothing at all when stderr is
!> not a terminal, so a redirected run prints what mlid run prints.
module mlid_batch_progress
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_size_t, c_char
  use mlid_progress, only: progress_t
  use mlid_text, only: itoa
  implicit none
  private
  public :: terminal_progress

  interface
    integer(c_int) function c_isatty(fd) bind(c, name='isatty')
      import :: c_int
      integer(c_int), value :: fd
    end function c_isatty
    integer(c_long) function c_write(fd, buf, n) bind(c, name='write')
      import :: c_int, c_long, c_size_t, c_char
      integer(c_int), value :: fd
      character(kind=c_char), intent(in) :: buf(*)
      integer(c_size_t), value :: n
    end function c_write
  end interface

contains

  !> Whether stderr is a terminal; if so, p tells the line there, from
  !> MLID_PROGRESS_QUIET_MS of work on when that is set (0: at once), else
  !> from the core's QUIET_MS.
  logical function terminal_progress(p)
    type(progress_t), intent(inout) :: p
    character(len=16) :: quiet
    integer :: n, ios, ms
    terminal_progress = c_isatty(2_c_int) == 1
    if (.not. terminal_progress) return
    p%tell => tell_line
    call get_environment_variable('MLID_PROGRESS_QUIET_MS', quiet, n)
    if (n == 0 .or. n > len(quiet)) return
    read (quiet, *, iostat=ios) ms
    if (ios == 0 .and. ms >= 0) p%quiet_ms = ms
  end function terminal_progress

  !> The line: a share of runs in per cent, or iterations against their
  !> ceiling (a fit stops when it converges, so no per cent of it is true).
  subroutine tell_line(label, done, total, exact, last)
    character(len=*), intent(in) :: label
    integer, intent(in) :: done, total
    logical, intent(in) :: exact, last
    character(len=:), allocatable :: text
    integer(c_long) :: put

    if (exact) then
      text = achar(13)//' '//trim(label)//' '//itoa(int(100.0*done/max(total, 1)))//'%'
    else
      text = achar(13)//' '//trim(label)//': iteration '//itoa(done)//' (at most '// &
             itoa(total)//')'
    end if
    if (last) text = text//achar(10)
    ! a terminal takes a line whole; what it does not take is not worth a retry
    put = c_write(2_c_int, text, int(len(text), c_size_t))
  end subroutine tell_line

end module mlid_batch_progress
