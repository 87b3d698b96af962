!> The one reader of text flight records, for both front ends.
!>
!> Tolerant of what real files carry: any line length, LF or CR-LF, a UTF-8
!> byte-order mark, blank lines, '#' comments with any bytes (also after
!> the data on a line), header lines before the first data row (the last
!> one with as many fields as there are columns names them), fields
!> separated by blanks, tabs or one comma, D exponents (1.0D+00).
!> Strict about what is wrong, each a message naming the file and line: a
!> list-directed repeat count (3*0.0), anything that is not a plain number
!> or not finite in a column that is used, rows with more or fewer columns
!> than the first, a column beyond the file's, no data rows, time that does
!> not increase, and a jump in time (two manoeuvres joined).
module mlid_record
  use, intrinsic :: iso_c_binding, only: c_char, c_double, c_ptr, c_null_char, c_loc, &
                                         c_intptr_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_value, ieee_positive_inf
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp, msg_len, MLID_OK, MLID_ERR_INPUT
  use mlid_files, only: file_stamp_t, file_stamp, file_changed
  use mlid_memory, only: no_memory
  use mlid_text, only: itoa, to_lower, text_file_t, text_open, text_line, text_close, &
                       control_character, short_path, line_t
  use mlid_units, only: UNITLEN
  use mlid_progress, only: progress_t, progress_start, progress_to, progress_stop
  implicit none
  private
  public :: record_t, record_read, record_text, NAMELEN

  integer, parameter :: NAMELEN = 32
  !> A record's progress is set every 8192 lines (a millisecond or so of them).
  integer, parameter :: PROGRESS_MASK = 8191

  !> A record as read: the columns asked for, x(size(cols), nrow), the
  !> file's column names and units (from its header, when it has one:
  !> 'ALCG[deg]' names ALCG with unit deg) and the file line of each row.
  type :: record_t
    real(wp), allocatable :: x(:, :)
    character(len=NAMELEN), allocatable :: names(:)
    character(len=UNITLEN), allocatable :: units(:)
    integer, allocatable :: line(:)
    integer :: ncol = 0
  end type record_t

  !> The header lines before the first data row, each a candidate for the
  !> line that names the columns: its text, file line and the offset of its
  !> text in that line (after a '#').
  type :: headers_t
    type(line_t), allocatable :: text(:)
    integer, allocatable :: line(:), off(:)
  end type headers_t

  interface
    !> C's decimal conversion of a field already checked to be a plain number.
    function strtod(str, stop) bind(c, name='strtod') result(x)
      import :: c_char, c_double, c_ptr
      character(kind=c_char), intent(in) :: str(*)
      type(c_ptr), intent(out) :: stop
      real(c_double) :: x
    end function strtod
  end interface

contains

  !> Read the columns cols (from 1) of a text record, after skip_rows lines
  !> skipped as they are.  header_only: stop at the first data row (for the
  !> column names and their number).  Time is the caller's to check: it
  !> knows which column holds it and which window it takes.  progress: the
  !> share of the file's text taken, in per cent (mlid_progress).
  subroutine record_read(path, cols, skip_rows, rec, status, msg, header_only, progress)
    character(len=*), intent(in) :: path
    integer, intent(in) :: cols(:), skip_rows
    type(record_t), intent(out) :: rec
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    logical, intent(in), optional :: header_only
    type(progress_t), intent(inout), optional :: progress
    character(len=:), allocatable :: line
    type(headers_t) :: heads
    character(len=:), allocatable :: bad
    type(text_file_t) :: tf
    type(file_stamp_t) :: stamp
    integer :: nline, nrow, ios, k
    logical :: only_header

    only_header = .false.
    if (present(header_only)) only_header = header_only
    allocate (rec%x(size(cols), 0), rec%names(0), rec%units(0), rec%line(0))
    stamp = file_stamp(path)
    call text_open(path, 'data file ', tf, status, msg, by_line=only_header)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    allocate (heads%text(0), heads%line(0), heads%off(0))
    nline = 0
    nrow = 0
    if (allocated(tf%text)) call progress_start(progress, 'reading '// &
                                                path(index(path, '/', back=.true.) + 1:), 100, .true.)
    do
      call text_line(tf, line, ios)
      if (ios /= 0) exit
      nline = nline + 1
      if (iand(nline, PROGRESS_MASK) == 0 .and. allocated(tf%text)) &
        call progress_to(progress, int(100*(tf%pos - 1)/max(1_int64, len(tf%text, int64))))
      if (nline <= skip_rows) then
        call add_header(heads, line, nline, 0)    ! a line skipped may name the columns
        cycle
      end if
      call take_line(line, nline, nrow, heads, rec, cols, only_header, msg)
      if (len_trim(msg) > 0) then
        call text_close(tf)
        call progress_stop(progress)
        msg = 'data file '//short_path(path)//' line '//itoa(nline)//': '//trim(msg)
        if (len(file_changed(path, stamp)) > 0) &     ! a row cut by a writer: say that
          msg = 'data file '//short_path(path)//' '//file_changed(path, stamp)
        return
      end if
      if (only_header .and. rec%ncol > 0) exit
    end do
    if (allocated(tf%text)) call progress_to(progress, 100)
    call progress_stop(progress)
    call text_close(tf)
    if (ios > 0) then
      msg = 'data file '//short_path(path)//': cannot be read'
      return
    end if
    msg = file_changed(path, stamp)
    if (len_trim(msg) > 0) then
      msg = 'data file '//short_path(path)//' '//trim(msg)
      return
    end if
    if (rec%ncol == 0) then
      msg = 'data file '//short_path(path)//': no data rows'
      return
    end if
    deallocate (rec%names, rec%units)
    allocate (rec%names(rec%ncol), rec%units(rec%ncol))
    rec%names = ''
    rec%units = ''
    ! the last with a name per column and no control character; one with a
    ! control character is refused only when no clean one names the columns
    bad = ''
    do k = size(heads%line), 1, -1
      call names_of(heads%text(k)%s, rec%ncol, rec%names, rec%units, heads%off(k), msg)
      if (len_trim(msg) > 0 .and. len(bad) == 0) &
        bad = 'data file '//short_path(path)//' line '//itoa(heads%line(k))//': '//trim(msg)
      if (any(rec%names /= '')) exit
    end do
    if (all(rec%names == '') .and. len(bad) > 0) then
      msg = bad
      return
    end if
    rec%x = rec%x(:, 1:nrow)
    rec%line = rec%line(1:nrow)
    status = MLID_OK
    msg = ''
  end subroutine record_read

  !> Classify one line (blank, comment, header, data row) and take a data
  !> row's columns into rec; msg is non-blank for a line that is wrong.
  subroutine take_line(line, nline, nrow, heads, rec, cols, only_header, msg)
    character(len=*), intent(in) :: line
    integer, intent(in) :: nline, cols(:)
    integer, intent(inout) :: nrow
    type(headers_t), intent(inout) :: heads
    type(record_t), intent(inout) :: rec
    logical, intent(in) :: only_header
    character(len=*), intent(out) :: msg
    integer, allocatable :: first(:), last(:)
    integer :: hash, ncol, n

    hash = index(line, '#')
    ! a comment may hold any bytes (the header that names the columns is
    ! checked where it is taken, record_read); what is read may not
    n = len(line)
    if (hash > 0) n = hash - 1
    msg = control_character(line(1:n))
    if (len_trim(msg) > 0) return
    if (hash > 0) then
      if (rec%ncol == 0 .and. len_trim(line(1:hash - 1)) == 0) then
        call add_header(heads, line(hash + 1:), nline, hash)
      end if
      call fields(line(1:hash - 1), first, last, msg)
    else
      call fields(line, first, last, msg)
    end if
    if (len_trim(msg) > 0 .or. size(first) == 0) return
    ncol = size(first)
    if (rec%ncol == 0) then
      if (.not. plain_number(line(first(1):last(1))) .and. &
          verify(line(first(1):first(1)), '+-.0123456789') > 0 .and. &
          .not. not_finite_word(line(first(1):last(1)))) then
        call add_header(heads, line, nline, 0)   ! a header line before the first data row
        return
      end if
      rec%ncol = ncol
      if (only_header) return
      if (size(cols) > 0) then
        if (maxval(cols) > ncol) then
          msg = 'column '//itoa(maxval(cols))//' requested, the file has '//itoa(ncol)//' columns'
          return
        end if
      end if
    end if
    call check_fields(line, first, last, msg)
    if (len_trim(msg) > 0) return
    if (ncol /= rec%ncol) then
      msg = itoa(ncol)//' columns, the first data row has '//itoa(rec%ncol)
      return
    end if
    call add_row(line, first, last, nline, nrow, rec, cols, msg)
  end subroutine take_line

  subroutine add_header(heads, text, nline, off)
    type(headers_t), intent(inout) :: heads
    character(len=*), intent(in) :: text
    integer, intent(in) :: nline, off
    heads%text = [heads%text, line_t(text)]
    heads%line = [heads%line, nline]
    heads%off = [heads%off, off]
  end subroutine add_header

  !> The requested columns of a data row, appended to rec.
  subroutine add_row(line, first, last, nline, nrow, rec, cols, msg)
    character(len=*), intent(in) :: line
    integer, intent(in) :: first(:), last(:), nline, cols(:)
    integer, intent(inout) :: nrow
    type(record_t), intent(inout) :: rec
    character(len=*), intent(out) :: msg
    integer :: k

    if (nrow == size(rec%x, 2)) call grow(rec, max(64, 2*nrow))
    nrow = nrow + 1
    rec%line(nrow) = nline
    do k = 1, size(cols)
      rec%x(k, nrow) = to_real(line(first(cols(k)):last(cols(k))))
    end do
    msg = ''
    if (all(ieee_is_finite(rec%x(:, nrow)))) return
    k = cols(findloc(ieee_is_finite(rec%x(:, nrow)), .false., 1))   ! 1e400: beyond a double
    msg = 'column '//itoa(k)//': '''//line(first(k):last(k))//''' is not finite'
  end subroutine add_row

  !> Every field of a data row a plain number (not only the columns taken):
  !> a repeat count or a word anywhere is refused.
  subroutine check_fields(line, first, last, msg)
    character(len=*), intent(in) :: line
    integer, intent(in) :: first(:), last(:)
    character(len=*), intent(out) :: msg
    integer :: k
    msg = ''
    do k = 1, size(first)
      if (plain_number(line(first(k):last(k)))) cycle
      if (index(line(first(k):last(k)), '*') > 0) then
        msg = 'column '//itoa(k)//': repeat count '''//line(first(k):last(k))// &
              ''' (write every value out)'
      else if (not_finite_word(line(first(k):last(k)))) then
        msg = 'column '//itoa(k)//': '''//line(first(k):last(k))//''' is not finite'
      else
        msg = 'column '//itoa(k)//': '''//line(first(k):last(k))//''' is not a number'
      end if
      return
    end do
  end subroutine check_fields

  subroutine grow(rec, n)
    type(record_t), intent(inout) :: rec
    integer, intent(in) :: n
    real(wp), allocatable :: x(:, :)
    integer, allocatable :: line(:)
    integer :: m
    m = size(rec%x, 2)
    allocate (x(size(rec%x, 1), n), line(n))
    x(:, 1:m) = rec%x
    line(1:m) = rec%line
    call move_alloc(x, rec%x)
    call move_alloc(line, rec%line)
  end subroutine grow

  !> Where the fields of a line start and end: separated by blanks, tabs
  !> and at most one comma (two commas, or a comma first or last, leave a
  !> field empty, which is an error); a field in double quotes is what they
  !> hold.
  subroutine fields(line, first, last, msg)
    character(len=*), intent(in) :: line
    integer, allocatable, intent(out) :: first(:), last(:)
    character(len=*), intent(out) :: msg
    integer :: k, n, m, pass
    logical :: inside, comma

    msg = ''
    n = len_trim(line)
    do pass = 1, 2            ! count the fields, then place them
      m = 0
      inside = .false.
      comma = .false.
      do k = 1, n
        if (line(k:k) == ' ' .or. line(k:k) == achar(9) .or. line(k:k) == ',') then
          if (inside .and. pass == 2) last(m) = k - 1
          if (line(k:k) == ',') then
            if (comma .or. m == 0) then
              msg = 'an empty field (two commas, or a comma first)'
              if (pass == 1) allocate (first(0), last(0))
              return
            end if
            comma = .true.
          end if
          inside = .false.
        else if (.not. inside) then
          m = m + 1
          if (pass == 2) first(m) = k
          inside = .true.
          comma = .false.
        end if
      end do
      if (pass == 1) allocate (first(m), last(m))
    end do
    if (inside) last(m) = n
    if (comma) msg = 'an empty field (a comma last)'
    do k = 1, m          ! "1.5" as a spreadsheet's CSV quotes every field: its text
      if (last(k) - first(k) >= 2 .and. line(first(k):first(k)) == '"' .and. &
          line(last(k):last(k)) == '"') then
        first(k) = first(k) + 1
        last(k) = last(k) - 1
      end if
    end do
  end subroutine fields

  !> A plain number: sign, digits with at most one point, an exponent with
  !> E or D; finite.
  !> A plain number's value: C's strtod (correctly rounded, and several
  !> times faster than a list-directed read); Fortran's read where strtod
  !> stops short (a locale whose decimal mark is not '.').
  real(wp) function to_real(field) result(x)
    character(len=*), intent(in) :: field
    character(kind=c_char), target :: buf(len(field) + 1)
    character(len=len(field)) :: f
    type(c_ptr) :: stop
    integer :: k, ios
    do k = 1, len(field)
      buf(k) = field(k:k)
      if (buf(k) == 'd' .or. buf(k) == 'D') buf(k) = 'e'
    end do
    buf(len(field) + 1) = c_null_char
    x = strtod(buf, stop)
    if (transfer(stop, 0_c_intptr_t) - transfer(c_loc(buf), 0_c_intptr_t) == len(field)) return
    f = field
    k = scan(f, 'dD')
    if (k > 0) f(k:k) = 'e'
    read (f, *, iostat=ios) x
    if (ios /= 0) x = ieee_value(x, ieee_positive_inf)   ! taken as not finite
  end function to_real

  logical function plain_number(s)
    character(len=*), intent(in) :: s
    integer :: k, digits, e
    plain_number = .false.
    k = 1
    if (s(1:1) == '+' .or. s(1:1) == '-') k = 2
    e = scan(s, 'eEdD')
    if (e == 0) e = len(s) + 1
    if (k >= e) return
    digits = len(s(k:e - 1)) - count_char(s(k:e - 1), '.')
    if (count_char(s(k:e - 1), '.') > 1 .or. digits < 1) return
    if (verify(s(k:e - 1), '0123456789.') > 0) return
    if (e > len(s)) then
      plain_number = .true.
      return
    end if
    k = e + 1
    if (k <= len(s)) then
      if (s(k:k) == '+' .or. s(k:k) == '-') k = k + 1
    end if
    plain_number = k <= len(s) .and. verify(s(k:), '0123456789') == 0
  end function plain_number

  integer function count_char(s, c)
    character(len=*), intent(in) :: s
    character, intent(in) :: c
    integer :: k
    count_char = 0
    do k = 1, len(s)
      if (s(k:k) == c) count_char = count_char + 1
    end do
  end function count_char

  !> The column names and units of a header line with ncol fields (blanks
  !> otherwise): 'ALCG[deg]' or 'ALCG [deg]' is the column ALCG in deg.
  !> A line with ncol fields and a control character names nothing, and says
  !> why in msg (its character counted from hoff).
  subroutine names_of(header, ncol, names, units, hoff, msg)
    character(len=*), intent(in) :: header
    integer, intent(in) :: ncol, hoff
    character(len=NAMELEN), intent(inout) :: names(:)   !< blank unless header names ncol columns
    character(len=UNITLEN), intent(inout) :: units(:)
    character(len=*), intent(out) :: msg
    character(len=len(header)) :: h
    integer, allocatable :: first(:), last(:)
    integer :: k, b
    h = header
    do k = len_trim(h), 2, -1        ! 'ALCG [deg]' -> 'ALCG[deg]'
      if (h(k:k) == '[' .and. h(k - 1:k - 1) == ' ') h(k - 1:) = h(k:)
    end do
    call fields(h, first, last, msg)
    if (size(first) /= ncol .or. len_trim(msg) > 0) then
      msg = ''
      return
    end if
    msg = control_character(header, hoff)      ! no names from a line with one
    if (len_trim(msg) > 0) return
    do k = 1, ncol
      b = index(h(first(k):last(k)), '[')
      if (b > 1 .and. h(last(k):last(k)) == ']') then
        names(k) = h(first(k):first(k) + b - 2)
        units(k) = h(first(k) + b:last(k) - 1)
      else
        names(k) = h(first(k):last(k))
      end if
    end do
  end subroutine names_of

  !> The text of a record as this reader reads it back: a '#' header line
  !> naming the columns with their units ('t[s] ax[m/s2] ...') and a row
  !> per sample, every value to 17 digits (exact).
  subroutine record_text(names, units, t, u, y, text, status, msg, first_line)
    character(len=*), intent(in) :: names(:), units(:)   !< the inputs', then the outputs'
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    character(len=:), allocatable, intent(out) :: text
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=*), intent(in), optional :: first_line  !< in place of the names' header
    character(len=:), allocatable :: header
    character(len=25) :: field
    integer(int64) :: w
    integer :: j, k, ist

    header = '# t[s]'
    do k = 1, size(names)
      header = header//' '//trim(names(k))
      if (len_trim(units(k)) > 0) header = header//'['//trim(units(k))//']'
    end do
    if (present(first_line)) header = first_line
    ! rows of 25 characters a value and a newline (64-bit: a long record passes 2**31)
    allocate (character(len=len(header) + (25_int64*(1 + size(u, 1) + size(y, 1)) + 1)* &
                        size(t) + 1) :: text, stat=ist)
    if (ist /= 0) then
      call no_memory('the text of a record of '//itoa(size(t))//' samples', &
                     (25.0_wp*(1 + size(u, 1) + size(y, 1)) + 1)*size(t)/8, status, msg)
      return
    end if
    status = MLID_OK
    msg = ''
    w = len(header) + 1
    text(1:w - 1) = header
    text(w:w) = achar(10)
    do j = 1, size(t)
      do k = 0, size(u, 1) + size(y, 1)
        if (k == 0) then
          write (field, '(es25.16e3)') t(j)
        else if (k <= size(u, 1)) then
          write (field, '(es25.16e3)') u(k, j)
        else
          write (field, '(es25.16e3)') y(k - size(u, 1), j)
        end if
        text(w + 1:w + 25) = field
        w = w + 25
      end do
      w = w + 1
      text(w:w) = achar(10)
    end do
  end subroutine record_text

  !> NaN or an infinity, as a field may spell them.
  logical function not_finite_word(field)
    character(len=*), intent(in) :: field
    character(len=len(field)) :: f
    f = to_lower(field)
    if (f(1:1) == '+' .or. f(1:1) == '-') f = f(2:)
    not_finite_word = f == 'nan' .or. f == 'inf' .or. f == 'infinity'
  end function not_finite_word

end module mlid_record
