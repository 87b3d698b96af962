!> What a binary flight record (.mat, HDF5) holds, as its table is made of
!> it: the numeric arrays in the file's order, each with numpy's shape of
!> it and, from HDF5, the attributes units (or unit) and columns; and the
!> rule that makes one table of them, the rule of tests/binary_reference.py's
!> _table, so that both front ends take the same channels of a file:
!>
!> - one 2-D matrix (both dimensions > 1) is the table, a row per sample
!>   (transposed first for a v7.3 .mat, which stores MATLAB's matrix
!>   transposed); its columns are named by its attribute columns
!>   ('ALCG[deg]' names ALCG with its unit), else left blank;
!> - several matrices are refused, unless a variable is named;
!> - else the vectors (1-D, or 2-D with a dimension 1) of more than one
!>   value, all of one length, side by side, named by their variables.
!>
!> The readers add only arrays numpy would call numeric (float, signed or
!> unsigned integers) with at least one value, as _table keeps only those.
module mlid_named_arrays
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: line_t, itoa, short_path
  implicit none
  private
  public :: named_array_t, arrays_put, arrays_table, printable, count_text

  !> One numeric array of a file: its name, numpy's shape of it, its values
  !> in column-major order over that shape (for 2-D, x(i, j) of the shape),
  !> and the text of its attributes units (else unit; '' when neither) and
  !> columns (unallocated when it has none).
  type :: named_array_t
    character(len=:), allocatable :: name
    integer(int64), allocatable :: shape(:)
    real(wp), allocatable :: v(:)
    character(len=:), allocatable :: units
    type(line_t), allocatable :: columns(:)
  end type named_array_t

  !> Python's str.strip() without arguments: the ASCII whitespace it strips.
  character(len=*), parameter :: WHITE = ' '//achar(9)//achar(10)//achar(11)//achar(12)// &
                                 achar(13)//achar(28)//achar(29)//achar(30)//achar(31)

contains

  !> Add item to list(1:n) (item is moved), or put it in the place of the
  !> array of its name, as a later variable of one name replaces the
  !> earlier in loadmat's dict.
  subroutine arrays_put(list, n, item, status, msg)
    type(named_array_t), allocatable, intent(inout) :: list(:)
    integer, intent(inout) :: n
    type(named_array_t), intent(inout) :: item
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(named_array_t), allocatable :: more(:)
    integer :: k, st

    status = MLID_OK
    msg = ''
    if (.not. allocated(item%units)) item%units = ''
    if (.not. allocated(list)) allocate (list(0))
    do k = 1, n
      if (list(k)%name == item%name .and. len(list(k)%name) == len(item%name)) then
        call move(item, list(k))
        return
      end if
    end do
    if (n == size(list)) then
      allocate (more(max(2*n, 8)), stat=st)
      if (st /= 0) goto 90
      do k = 1, n
        call move(list(k), more(k))
      end do
      call move_alloc(more, list)
    end if
    n = n + 1
    call move(item, list(n))
    return
90  status = MLID_ERR_INPUT
    msg = 'out of memory for '//itoa(2*n + 8)//' arrays'
  end subroutine arrays_put

  subroutine move(from, to)
    type(named_array_t), intent(inout) :: from, to
    call move_alloc(from%name, to%name)
    call move_alloc(from%shape, to%shape)
    call move_alloc(from%v, to%v)
    call move_alloc(from%units, to%units)
    if (allocated(to%columns)) deallocate (to%columns)
    if (allocated(from%columns)) call move_alloc(from%columns, to%columns)
  end subroutine move

  !> The table of arrays, x(nrow, ncol) with its columns' names and units
  !> ('' where the file names none), by the rule above.  variable: the
  !> array to take ('' for none named); transpose: a v7.3 .mat's matrix.
  !> names and units are as long as the caller's (longer ones are cut, as
  !> the flat interface cuts them).
  subroutine arrays_table(path, arrays, variable, transpose_matrix, x, names, units, status, msg)
    character(len=*), intent(in) :: path, variable
    type(named_array_t), intent(in) :: arrays(:)
    logical, intent(in) :: transpose_matrix
    real(wp), allocatable, intent(out) :: x(:, :)
    character(len=*), allocatable, intent(out) :: names(:), units(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    logical :: taken(size(arrays)), matrix(size(arrays)), vector(size(arrays))
    integer :: k, n

    status = MLID_ERR_INPUT
    taken = .true.
    if (len_trim(variable) > 0) then
      k = 0
      do n = 1, size(arrays)
        if (arrays(n)%name == trim(variable) .and. len(arrays(n)%name) == len_trim(variable)) &
          k = n
      end do
      if (k == 0) then
        msg = 'data file '//short_path(path)//': no numeric variable '''// &
              printable(trim(variable))//''' (it has: '//listed(arrays, taken)//')'
        return
      end if
      taken = [(n == k, n=1, size(arrays))]
    end if
    do k = 1, size(arrays)
      associate (s => arrays(k)%shape)
        matrix(k) = taken(k) .and. size(s) == 2
        if (matrix(k)) matrix(k) = minval(s) > 1
        vector(k) = taken(k) .and. size(s) <= 2 .and. product(s) > 1
      end associate
    end do
    if (count(matrix) == 1) then
      call matrix_table(path, arrays(findloc(matrix, .true., 1)), transpose_matrix, x, names, &
                        units, status, msg)
    else if (count(matrix) > 1) then
      msg = 'data file '//short_path(path)//': several matrices ('//listed(arrays, matrix)// &
            '); name one with variable='
    else
      call vector_table(path, arrays, vector, x, names, units, status, msg)
    end if
  end subroutine arrays_table

  !> The one matrix, a row per sample, its columns named by its attribute
  !> columns when it has one.
  subroutine matrix_table(path, a, transpose_matrix, x, names, units, status, msg)
    character(len=*), intent(in) :: path
    type(named_array_t), intent(in) :: a
    logical, intent(in) :: transpose_matrix
    real(wp), allocatable, intent(out) :: x(:, :)
    character(len=*), allocatable, intent(out) :: names(:), units(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer(int64) :: nr, nc
    integer :: k, st, b

    status = MLID_ERR_INPUT
    nr = a%shape(1)
    nc = a%shape(2)
    if (transpose_matrix) then
      allocate (x(nc, nr), stat=st)
      if (st == 0) x = transpose(reshape(a%v, [nr, nc]))
    else
      allocate (x(nr, nc), stat=st)
      if (st == 0) x = reshape(a%v, [nr, nc])
    end if
    if (st /= 0) then
      msg = 'data file '//short_path(path)//': out of memory for its '//count_text(nr)//' x '// &
            count_text(nc)//' matrix'
      return
    end if
    allocate (names(size(x, 2)), units(size(x, 2)), stat=st)
    if (st /= 0) then
      msg = 'data file '//short_path(path)//': out of memory for '//itoa(size(x, 2))//' names'
      return
    end if
    names = ''
    units = ''
    if (allocated(a%columns)) then
      if (size(a%columns) /= size(x, 2)) then
        msg = 'data file '//short_path(path)//': '//itoa(size(a%columns))// &
              ' column names for '//itoa(size(x, 2))//' columns'
        return
      end if
      do k = 1, size(x, 2)
        associate (c => a%columns(k)%s)
          b = index(c, '[')
          if (b == 0) then
            names(k) = stripped(c)
          else
            names(k) = stripped(c(1:b - 1))
            units(k) = stripped(without_brackets(c(b + 1:)))
          end if
        end associate
      end do
    end if
    status = MLID_OK
    msg = ''
  end subroutine matrix_table

  !> The vectors of the arrays marked, side by side, named by their names,
  !> with their units.  They must all have one length.
  subroutine vector_table(path, arrays, vector, x, names, units, status, msg)
    character(len=*), intent(in) :: path
    type(named_array_t), intent(in) :: arrays(:)
    logical, intent(in) :: vector(:)
    real(wp), allocatable, intent(out) :: x(:, :)
    character(len=*), allocatable, intent(out) :: names(:), units(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, j, nrow, st

    status = MLID_ERR_INPUT
    nrow = 0
    do k = 1, size(arrays)
      if (.not. vector(k)) cycle
      if (nrow == 0) nrow = size(arrays(k)%v)
      if (size(arrays(k)%v) /= nrow) nrow = -1
    end do
    if (nrow <= 0) then
      msg = 'data file '//short_path(path)//': no matrix and no channel vectors of one length'
      return
    end if
    allocate (x(nrow, count(vector)), names(count(vector)), units(count(vector)), stat=st)
    if (st /= 0) then
      msg = 'data file '//short_path(path)//': out of memory for '//itoa(count(vector))// &
            ' vectors of '//itoa(nrow)
      return
    end if
    j = 0
    do k = 1, size(arrays)
      if (.not. vector(k)) cycle
      j = j + 1
      x(:, j) = arrays(k)%v
      names(j) = arrays(k)%name
      units(j) = arrays(k)%units
    end do
    status = MLID_OK
    msg = ''
  end subroutine vector_table

  !> The names of the arrays marked, sorted (Python's sorted(): by code
  !> point, which is UTF-8's byte order), ', '-separated; 'none' for none.
  function listed(arrays, marked) result(text)
    type(named_array_t), intent(in) :: arrays(:)
    logical, intent(in) :: marked(:)
    character(len=:), allocatable :: text
    integer, allocatable :: order(:)
    integer :: i, j, t

    order = pack([(i, i=1, size(arrays))], marked)
    do i = 2, size(order)                 ! insertion sort: a file has few arrays
      t = order(i)
      j = i - 1
      do while (j >= 1)
        if (.not. before(arrays(t)%name, arrays(order(j))%name)) exit
        order(j + 1) = order(j)
        j = j - 1
      end do
      order(j + 1) = t
    end do
    text = ''
    do i = 1, size(order)
      if (i > 1) text = text//', '
      text = text//printable(arrays(order(i))%name)
      if (len(text) > 160) then         ! the message keeps to one line of msg_len
        text = text//', ...'
        exit
      end if
    end do
    if (size(order) == 0) text = 'none'
  end function listed

  !> a before b by bytes, a prefix before what it begins.
  pure logical function before(a, b)
    character(len=*), intent(in) :: a, b
    integer :: k
    do k = 1, min(len(a), len(b))
      if (a(k:k) /= b(k:k)) then
        before = ichar(a(k:k)) < ichar(b(k:k))
        return
      end if
    end do
    before = len(a) < len(b)
  end function before

  !> text with control characters shown as '?': a message is one line.
  pure function printable(text) result(r)
    character(len=*), intent(in) :: text
    character(len=len(text)) :: r
    integer :: k
    r = text
    do k = 1, len(r)
      if (iachar(r(k:k)) < 32 .or. iachar(r(k:k)) == 127) r(k:k) = '?'
    end do
  end function printable

  !> Python's text.strip().
  pure function stripped(text) result(r)
    character(len=*), intent(in) :: text
    character(len=:), allocatable :: r
    integer :: a, b
    a = verify(text, WHITE)
    b = verify(text, WHITE, back=.true.)
    r = ''
    if (a > 0) r = text(a:b)
  end function stripped

  !> A count of any integer kind for a message.
  function count_text(i) result(text)
    class(*), intent(in) :: i
    character(len=:), allocatable :: text
    character(len=24) :: buf
    select type (i)
    type is (integer)
      write (buf, '(i0)') i
    type is (integer(int64))
      write (buf, '(i0)') i
    class default
      buf = '?'
    end select
    text = trim(buf)
  end function count_text

  !> Python's text.rstrip(']').
  pure function without_brackets(text) result(r)
    character(len=*), intent(in) :: text
    character(len=:), allocatable :: r
    r = text(1:verify(text, ']', back=.true.))
  end function without_brackets

end module mlid_named_arrays
