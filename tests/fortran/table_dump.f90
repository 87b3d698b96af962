!> The table the core reads of a .mat or HDF5 record, for the Python tests
!> to hold against tests/binary_reference.py's read_table:
!>   table_dump FILE OUT [VARIABLE]
!> prints 'status N', the message, and when N is 0 'nrow ncol' and a line
!> 'name<TAB>unit' per column; writes x (nrow, ncol), column-major
!> doubles, to OUT.  Exits 0 whatever the status (a crash is what fails).
!>   table_dump --threads FILE...
!> reads the files one after another, then each 8 times more from OpenMP
!> threads at once, and prints 'threads: N differ' (N reads whose status,
!> message or table differ from the first).
program table_dump
  use mlid_kinds, only: wp, MLID_OK
  use mlid_tablefile, only: tablefile_read
  implicit none
  type :: table_t
    real(wp), allocatable :: x(:, :)
    character(len=256), allocatable :: names(:), units(:)
    integer :: status = -1
    character(len=256) :: msg = ''
  end type table_t
  character(len=4096) :: path, out, variable
  type(table_t) :: tb

  call get_command_argument(1, path)
  if (path == '--threads') then
    call threads()
    stop
  end if
  call get_command_argument(2, out)
  variable = ''
  if (command_argument_count() > 2) call get_command_argument(3, variable)
  tb = table_of(trim(path), trim(variable))
  call show(tb, trim(out))

contains

  function table_of(file, var) result(t)
    character(len=*), intent(in) :: file, var
    type(table_t) :: t
    call tablefile_read(file, var, t%x, t%names, t%units, t%status, t%msg)
  end function table_of

  subroutine show(t, file)
    type(table_t), intent(in) :: t
    character(len=*), intent(in) :: file
    integer :: k, u
    write (*, '(a, i0)') 'status ', t%status
    write (*, '(a)') trim(t%msg)
    if (t%status /= MLID_OK) return
    write (*, '(i0, 1x, i0)') size(t%x, 1), size(t%x, 2)
    do k = 1, size(t%names)
      write (*, '(a)') trim(t%names(k))//achar(9)//trim(t%units(k))
    end do
    open (newunit=u, file=file, access='stream', form='unformatted', status='replace', &
          action='write')
    write (u) t%x
    close (u)
  end subroutine show

  subroutine threads()
    character(len=4096), allocatable :: files(:)
    type(table_t), allocatable :: first(:)
    type(table_t) :: again
    integer :: k, n, bad
    n = command_argument_count() - 1
    allocate (files(n), first(n))
    do k = 1, n
      call get_command_argument(k + 1, files(k))
      first(k) = table_of(trim(files(k)), '')
    end do
    bad = 0
    !$omp parallel do private(again) reduction(+:bad) schedule(dynamic)
    do k = 1, 8*n
      again = table_of(trim(files(mod(k, n) + 1)), '')
      if (.not. same(again, first(mod(k, n) + 1))) bad = bad + 1
    end do
    !$omp end parallel do
    write (*, '(a, i0, a)') 'threads: ', bad, ' differ'
  end subroutine threads

  logical function same(a, b)
    type(table_t), intent(in) :: a, b
    same = a%status == b%status .and. a%msg == b%msg
    if (.not. same .or. a%status /= MLID_OK) return
    same = all(shape(a%x) == shape(b%x)) .and. size(a%names) == size(b%names)
    if (same) same = all(a%x == b%x .or. (a%x /= a%x .and. b%x /= b%x)) .and. &
                     all(a%names == b%names) .and. all(a%units == b%units)
  end function same

end program table_dump
