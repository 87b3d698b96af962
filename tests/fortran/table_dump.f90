!> The table the core reads of a .mat or HDF5 record, for the Python tests
!> to hold against python/mlid/formats.py's read_table:
!>   table_dump FILE OUT [VARIABLE]
!> prints 'status N', the message, and when N is 0 'nrow ncol' and a line
!> 'name<TAB>unit' per column; writes x (nrow, ncol), column-major
!> doubles, to OUT.  Exits 0 whatever the status (a crash is what fails).
program table_dump
  use mlid_kinds, only: wp, MLID_OK
  use mlid_tablefile, only: tablefile_read
  implicit none
  character(len=4096) :: path, out, variable
  character(len=256) :: msg
  character(len=256), allocatable :: names(:), units(:)
  real(wp), allocatable :: x(:, :)
  integer :: status, k, u

  call get_command_argument(1, path)
  call get_command_argument(2, out)
  variable = ''
  if (command_argument_count() > 2) call get_command_argument(3, variable)
  call tablefile_read(trim(path), trim(variable), x, names, units, status, msg)
  write (*, '(a, i0)') 'status ', status
  write (*, '(a)') trim(msg)
  if (status /= MLID_OK) stop
  write (*, '(i0, 1x, i0)') size(x, 1), size(x, 2)
  do k = 1, size(names)
    write (*, '(a)') trim(names(k))//achar(9)//trim(units(k))
  end do
  open (newunit=u, file=trim(out), access='stream', form='unformatted', status='replace', &
        action='write')
  write (u) x
  close (u)
end program table_dump
