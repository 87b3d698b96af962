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
  use mlid_text, only: itoa, to_lower, text_file_t, text_open, text_line, text_close, &
                       control_character
  implicit none
  private
  public :: record_t, record_read, record_text, record_check_time, record_check_segments, &
            record_uniform_step, record_common_step, short_path, seconds, number_text, &
            GAP_FACTOR, UNIFORM_TOL, NAMELEN, UNITLEN

  !> A time step larger than this times the median step is a gap.
  real(wp), parameter :: GAP_FACTOR = 1.5_wp
  !> Uniform sampling: every step within this fraction of the mean step (the
  !> Fourier transforms, mlid_fourier's and mlid_fft's, take equal steps).
  real(wp), parameter :: UNIFORM_TOL = 1.0e-6_wp
  integer, parameter :: NAMELEN = 32, UNITLEN = 16

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
  !> knows which column holds it and which window it takes.
  subroutine record_read(path, cols, skip_rows, rec, status, msg, header_only)
    character(len=*), intent(in) :: path
    integer, intent(in) :: cols(:), skip_rows
    type(record_t), intent(out) :: rec
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    logical, intent(in), optional :: header_only
    character(len=:), allocatable :: line, header
    type(text_file_t) :: tf
    integer :: nline, nrow, ios, hline, hoff
    logical :: only_header

    only_header = .false.
    if (present(header_only)) only_header = header_only
    allocate (rec%x(size(cols), 0), rec%names(0), rec%units(0), rec%line(0))
    call text_open(path, 'data file ', tf, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    header = ''
    hline = 0
    hoff = 0
    nline = 0
    nrow = 0
    do
      call text_line(tf, line, ios)
      if (ios /= 0) exit
      nline = nline + 1
      if (nline <= skip_rows) then
        header = line             ! the last line skipped may name the columns
        hline = nline
        hoff = 0
        cycle
      end if
      call take_line(line, nline, nrow, header, hline, hoff, rec, cols, only_header, msg)
      if (len_trim(msg) > 0) then
        call text_close(tf)
        msg = 'data file '//short_path(path)//' line '//itoa(nline)//': '//trim(msg)
        return
      end if
      if (only_header .and. rec%ncol > 0) exit
    end do
    call text_close(tf)
    if (ios > 0) then
      msg = 'data file '//short_path(path)//': cannot be read'
      return
    end if
    if (rec%ncol == 0) then
      msg = 'data file '//short_path(path)//': no data rows'
      return
    end if
    msg = control_character(header, hoff)        ! the line that names the columns
    if (len_trim(msg) > 0) then
      msg = 'data file '//short_path(path)//' line '//itoa(hline)//': '//trim(msg)
      return
    end if
    rec%x = rec%x(:, 1:nrow)
    rec%line = rec%line(1:nrow)
    call names_of(header, rec%ncol, rec%names, rec%units)
    status = MLID_OK
    msg = ''
  end subroutine record_read

  !> Classify one line (blank, comment, header, data row) and take a data
  !> row's columns into rec; msg is non-blank for a line that is wrong.
  subroutine take_line(line, nline, nrow, header, hline, hoff, rec, cols, only_header, msg)
    character(len=*), intent(in) :: line
    integer, intent(in) :: nline, cols(:)
    integer, intent(inout) :: nrow, hline, hoff   !< the header's line, where it starts less 1
    character(len=:), allocatable, intent(inout) :: header
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
        header = line(hash + 1:)
        hline = nline
        hoff = hash
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
        header = line                      ! a header line before the first data row
        hline = nline
        hoff = 0
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
  !> field empty, which is an error).
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
  subroutine names_of(header, ncol, names, units)
    character(len=*), intent(in) :: header
    integer, intent(in) :: ncol
    character(len=NAMELEN), allocatable, intent(out) :: names(:)
    character(len=UNITLEN), allocatable, intent(out) :: units(:)
    character(len=len(header)) :: h
    integer, allocatable :: first(:), last(:)
    character(len=msg_len) :: msg
    integer :: k, b
    allocate (names(ncol), units(ncol))
    names = ''
    units = ''
    h = header
    do k = len_trim(h), 2, -1        ! 'ALCG [deg]' -> 'ALCG[deg]'
      if (h(k:k) == '[' .and. h(k - 1:k - 1) == ' ') h(k - 1:) = h(k:)
    end do
    call fields(h, first, last, msg)
    if (size(first) /= ncol .or. len_trim(msg) > 0) return
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
  function record_text(names, units, t, u, y) result(text)
    character(len=*), intent(in) :: names(:), units(:)   !< the inputs', then the outputs'
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    character(len=:), allocatable :: text
    character(len=25) :: field
    integer(int64) :: w
    integer :: j, k

    text = '# t[s]'
    do k = 1, size(names)
      text = text//' '//trim(names(k))
      if (len_trim(units(k)) > 0) text = text//'['//trim(units(k))//']'
    end do
    w = len(text) + 1
    ! rows of 25 characters a value and a newline (64-bit: a long record passes 2**31)
    text = text//repeat(' ', (25_int64*(1 + size(u, 1) + size(y, 1)) + 1)*size(t) + 1)
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
  end function record_text

  !> Time must increase, and a step larger than GAP_FACTOR times the median
  !> step is a gap: two manoeuvres joined.  at: the sample where it happens.
  subroutine record_check_time(t, at, status, msg)
    real(wp), intent(in) :: t(:)
    integer, intent(out) :: at, status
    character(len=*), intent(out) :: msg
    real(wp) :: dt(max(size(t) - 1, 0)), med
    integer :: k

    status = MLID_OK
    msg = ''
    at = 0
    do k = 2, size(t)
      if (.not. t(k) > t(k - 1)) then
        status = MLID_ERR_INPUT
        at = k
        msg = 'time does not increase: '//seconds(t(k))//' after '//seconds(t(k - 1))// &
              ' (sample '//itoa(k)//')'
        return
      end if
    end do
    if (size(t) < 3) return
    dt = t(2:) - t(:size(t) - 1)
    med = median(dt)
    do k = 1, size(dt)
      if (dt(k) > GAP_FACTOR*med) then
        status = MLID_ERR_INPUT
        at = k + 1
        msg = 'a gap in time from '//seconds(t(k))//' to '//seconds(t(k + 1))//' at sample '// &
              itoa(k + 1)//' (sampling '//seconds(med)//'): split the record into manoeuvres '// &
              '(several files, or windows t_start/t_end of one)'
        return
      end if
    end do
  end subroutine record_check_time

  !> record_check_time for each manoeuvre of a joined record (segstart:
  !> the first sample of each); the message names the manoeuvre.
  subroutine record_check_segments(t, segstart, status, msg)
    real(wp), intent(in) :: t(:)
    integer, intent(in) :: segstart(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, first, last, at
    status = MLID_OK
    msg = ''
    do k = 1, size(segstart)
      call manoeuvre_bounds(segstart, k, size(t), first, last)
      if (last <= first) cycle
      call record_check_time(t(first:last), at, status, msg)
      if (status /= MLID_OK) then
        if (size(segstart) > 1) msg = 'manoeuvre '//itoa(k)//': '//trim(msg)
        msg = 'data: '//trim(msg)
        return
      end if
    end do
  end subroutine record_check_segments

  !> dt, the mean step of t, when t is uniformly sampled (every step within
  !> UNIFORM_TOL of dt): what the frequency-domain tools take.  Else a
  !> message naming the sample whose step is farthest from dt.
  subroutine record_uniform_step(t, dt, status, msg)
    real(wp), intent(in) :: t(:)
    real(wp), intent(out) :: dt
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: n, k
    n = size(t)
    dt = 0.0_wp
    status = MLID_ERR_INPUT
    if (n < 2) then
      msg = 'a record to transform needs at least two samples'
      return
    else if (.not. all(ieee_is_finite(t))) then
      msg = 'time is not finite at sample '//itoa(findloc(ieee_is_finite(t), .false., 1))
      return
    end if
    dt = (t(n) - t(1))/(n - 1)
    if (.not. dt > 0.0_wp) then
      msg = 'time must increase over a record to transform'
      return
    end if
    k = maxloc(abs(t(2:) - t(:n - 1) - dt), 1)
    if (abs(t(k + 1) - t(k) - dt) > UNIFORM_TOL*dt) then
      msg = 'time is not uniformly sampled: the step to sample '//itoa(k + 1)//' (t = '// &
            seconds(t(k + 1))//') is '//precise(t(k + 1) - t(k))//' s, the mean step '// &
            precise(dt)//' s (the frequency-domain tools need equal steps, to 1e-6 of the mean)'
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine record_uniform_step

  !> A step for a message, to the digits that UNIFORM_TOL tells apart.
  function precise(x) result(text)
    real(wp), intent(in) :: x
    character(len=:), allocatable :: text
    character(len=24) :: buf
    write (buf, '(es16.9)') x
    text = trim(adjustl(buf))
  end function precise

  !> The one step dt of the manoeuvres of t starting at samples starts: each
  !> uniformly sampled (record_uniform_step), all at the first's step to
  !> UNIFORM_TOL; the message names the manoeuvre when there are several.
  subroutine record_common_step(t, starts, dt, status, msg)
    real(wp), intent(in) :: t(:)
    integer, intent(in) :: starts(:)
    real(wp), intent(out) :: dt
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: d
    integer :: k, j0, j1
    dt = 0.0_wp
    status = MLID_ERR_INPUT
    msg = 'a record to transform needs at least two samples'
    do k = 1, size(starts)
      call manoeuvre_bounds(starts, k, size(t), j0, j1)
      call record_uniform_step(t(j0:j1), d, status, msg)
      if (status == MLID_OK .and. k > 1 .and. .not. abs(d - dt) <= UNIFORM_TOL*dt) then
        status = MLID_ERR_INPUT
        msg = 'its step '//precise(d)//' s is not manoeuvre 1''s '//precise(dt)// &
              ' s: the manoeuvres of a frequency response need one sampling interval'
      end if
      if (status /= MLID_OK) then
        if (size(starts) > 1) msg = 'manoeuvre '//itoa(k)//': '//trim(msg)
        return
      end if
      if (k == 1) dt = d
    end do
  end subroutine record_common_step

  !> The first and last sample of manoeuvre k of n samples whose manoeuvres
  !> start at the samples starts (clipped to 1 .. n).
  pure subroutine manoeuvre_bounds(starts, k, n, first, last)
    integer, intent(in) :: starts(:), k, n
    integer, intent(out) :: first, last
    first = max(1, starts(k))
    last = n
    if (k < size(starts)) last = min(n, starts(k + 1) - 1)
  end subroutine manoeuvre_bounds

  !> A path for a message: its last 60 characters, so the problem fits.
  function short_path(path) result(text)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: text
    text = trim(path)
    if (len(text) > 60) text = '...'//text(len(text) - 56:)
  end function short_path

  !> A time in seconds for a message: '12.34 s', '0.02 s', '1.5E+07 s'.
  function seconds(x) result(text)
    real(wp), intent(in) :: x
    character(len=:), allocatable :: text
    text = number_text(x)//' s'
  end function seconds

  !> A value for a message: '12.34', '0.02', '-57.29578', '1.5E+07'.
  function number_text(x) result(text)
    real(wp), intent(in) :: x
    character(len=:), allocatable :: text
    character(len=32) :: buf
    integer :: k
    if ((abs(x) >= 1.0e-3_wp .and. abs(x) < 1.0e7_wp) .or. x == 0.0_wp) then
      write (buf, '(f0.6)') x
      k = len_trim(buf)
      do while (buf(k:k) == '0')
        k = k - 1
      end do
      if (buf(k:k) == '.') k = k - 1
      text = trim(adjustl(buf(1:k)))
      if (len(text) == 0) text = '0'
      if (text(1:1) == '.') text = '0'//text
      if (text(1:2) == '-.') text = '-0'//text(2:)
    else
      write (buf, '(es10.3)') x
      text = trim(adjustl(buf))
    end if
  end function number_text

  !> NaN or an infinity, as a field may spell them.
  logical function not_finite_word(field)
    character(len=*), intent(in) :: field
    character(len=len(field)) :: f
    f = to_lower(field)
    if (f(1:1) == '+' .or. f(1:1) == '-') f = f(2:)
    not_finite_word = f == 'nan' .or. f == 'inf' .or. f == 'infinity'
  end function not_finite_word

  !> The median of x (quickselect on a copy).
  real(wp) function median(x)
    real(wp), intent(in) :: x(:)
    real(wp) :: a(size(x))
    a = x
    median = select_kth(a, (size(a) + 1)/2)
    if (mod(size(a), 2) == 0) median = 0.5_wp*(median + minval(a((size(a) + 1)/2 + 1:)))
  end function median

  !> The k-th smallest of a; a is left partitioned about it.
  real(wp) function select_kth(a, k)
    real(wp), intent(inout) :: a(:)
    integer, intent(in) :: k
    integer :: lo, hi, i, j
    real(wp) :: pivot
    lo = 1
    hi = size(a)
    do while (lo < hi)
      pivot = a((lo + hi)/2)
      i = lo
      j = hi
      do while (i <= j)
        do while (a(i) < pivot)
          i = i + 1
        end do
        do while (a(j) > pivot)
          j = j - 1
        end do
        if (i <= j) then
          a([i, j]) = a([j, i])
          i = i + 1
          j = j - 1
        end if
      end do
      if (k <= j) then
        hi = j
      else if (k >= i) then
        lo = i
      else
        exit
      end if
    end do
    select_kth = a(k)
  end function select_kth

end module mlid_record
