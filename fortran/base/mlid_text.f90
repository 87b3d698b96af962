!> Small text helpers shared by the readers and the flat interface, and
!> the opening and reading of text files of any line length.
module mlid_text
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_files, only: not_regular, file_stamp_t, file_stamp, file_changed
  implicit none
  private
  public :: to_lower, to_upper, itoa, joined, join_lines, split_lines, name_lines, text_lines, read_text, line_t, &
            text_file_t, text_open, text_line, text_close, control_character, comment_start, &
            short_path, seconds, number_text, es_text, fixed_text, add_line, utf8_head, choices

  integer, parameter :: CHUNK = 4096
  character(len=3), parameter :: BOM = char(239)//char(187)//char(191)   !< UTF-8 byte-order mark

  !> One line of text (gfortran mishandles arrays of deferred-length
  !> character as components; an array of these does not).
  type :: line_t
    character(len=:), allocatable :: s
  end type line_t

  !> A text file being read line by line (text_open, text_line, text_close).
  type :: text_file_t
    character(len=:), allocatable :: text      !< all of it, read at once, or else
    integer :: unit = 0                        !< its unit, read line by line
    integer(int64) :: pos = 1                  !< where the next line starts in text
    integer :: nline = 0                       !< lines given so far
  end type text_file_t

contains

  !> 'a', 'b' or 'c': a list of choices for a message.
  pure function choices(list) result(text)
    character(len=*), intent(in) :: list(:)
    character(len=:), allocatable :: text
    integer :: k
    text = ''''//trim(list(1))//''''
    do k = 2, size(list)
      if (k == size(list)) then
        text = text//' or '''//trim(list(k))//''''
      else
        text = text//', '''//trim(list(k))//''''
      end if
    end do
  end function choices

  elemental function to_lower(s) result(r)
    character(len=*), intent(in) :: s
    character(len=len(s)) :: r
    integer :: k
    r = s
    do k = 1, len(s)
      if (s(k:k) >= 'A' .and. s(k:k) <= 'Z') r(k:k) = achar(iachar(s(k:k)) + 32)
    end do
  end function to_lower

  elemental function to_upper(s) result(r)
    character(len=*), intent(in) :: s
    character(len=len(s)) :: r
    integer :: k
    r = s
    do k = 1, len(s)
      if (s(k:k) >= 'a' .and. s(k:k) <= 'z') r(k:k) = achar(iachar(s(k:k)) - 32)
    end do
  end function to_upper

  function itoa(i) result(s)
    integer, intent(in) :: i
    character(len=:), allocatable :: s
    character(len=16) :: buf
    write (buf, '(i0)') i
    s = trim(buf)
  end function itoa

  !> text cut to at most n bytes at a UTF-8 character boundary, a character
  !> cut short at its end dropped too (a message quoting a name never ends
  !> inside a character): a lead byte 110xxxxx, 1110xxxx or 11110xxx starts a
  !> character of 2, 3 or 4 bytes; any other byte is one of its own.
  pure function utf8_head(text, n) result(head)
    character(len=*), intent(in) :: text
    integer, intent(in) :: n
    character(len=:), allocatable :: head
    integer :: k, p, b, need
    k = min(max(n, 0), len(text))
    p = k                                 ! where the last character starts
    do while (p > 1 .and. p > k - 3)
      if (iand(iachar(text(p:p)), 192) /= 128) exit
      p = p - 1
    end do
    need = 1
    if (p >= 1) then
      b = iachar(text(p:p))
      if (iand(b, 224) == 192) need = 2
      if (iand(b, 240) == 224) need = 3
      if (iand(b, 248) == 240) need = 4
      if (p + need - 1 > k) k = p - 1
    end if
    head = text(1:k)
  end function utf8_head

  !> 'a, b, c'
  function joined(names) result(text)
    character(len=*), intent(in) :: names(:)
    character(len=:), allocatable :: text
    integer :: k
    text = ''
    do k = 1, size(names)
      text = text//trim(names(k))
      if (k < size(names)) text = text//', '
    end do
  end function joined

  !> Names one per line, for the flat interface.
  function join_lines(names) result(text)
    character(len=*), allocatable, intent(in) :: names(:)
    character(len=:), allocatable :: text
    integer :: j
    text = ''
    if (.not. allocated(names)) return
    do j = 1, size(names)
      text = text//trim(names(j))//achar(10)
    end do
  end function join_lines

  !> The first n lines of text (names one per line).
  function split_lines(text, n, width) result(names)
    character(len=*), intent(in) :: text
    integer, intent(in) :: n, width
    character(len=width) :: names(n)
    integer :: j, p, e
    names = ''
    p = 1
    do j = 1, n
      if (p > len(text)) exit
      e = index(text(p:), achar(10))
      if (e == 0) e = len(text) - p + 2
      names(j) = text(p:p + e - 2)
      p = p + e
    end do
  end function split_lines

  !> Every line of text, each newline-ended: names one a line, as the flat
  !> interface passes them.  (Not split_lines at the names' length: gfortran
  !> 12 fails on that internally.)
  subroutine name_lines(text, names)
    character(len=*), intent(in) :: text
    character(len=*), allocatable, intent(out) :: names(:)
    integer :: k, p, e
    allocate (names(count([(text(k:k) == achar(10), k=1, len(text))])))
    names = ''
    p = 1
    do k = 1, size(names)
      e = index(text(p:), achar(10))
      names(k) = text(p:p + e - 2)
      p = p + e
    end do
  end subroutine name_lines

  !> The non-blank lines of text (lines separated by newlines), trimmed.
  function text_lines(text) result(lines)
    character(len=*), intent(in) :: text
    type(line_t), allocatable :: lines(:)
    integer :: p, e
    allocate (lines(0))
    p = 1
    do while (p <= len(text))
      e = index(text(p:), achar(10))
      if (e == 0) e = len(text) - p + 2
      if (len_trim(text(p:p + e - 2)) > 0) lines = [lines, line_t(trim(adjustl(text(p:p + e - 2))))]
      p = p + e
    end do
  end function text_lines

  !> Open a text file to read line by line: held whole in memory when it
  !> can be read at once (fast), else read line by line from a formatted
  !> unit.  A missing file, or one that is no regular file (a directory, a
  !> FIFO, a device), is refused.
  subroutine text_open(path, what, tf, status, msg, by_line)
    character(len=*), intent(in) :: path, what
    type(text_file_t), intent(out) :: tf
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    !> read line by line even when it could be held whole (a reader that
    !> stops early, at a record's first data row, reads only that far)
    logical, intent(in), optional :: by_line
    integer(int64) :: size_bytes
    logical :: exists
    integer :: unit

    status = MLID_ERR_INPUT
    inquire (file=path, exist=exists, size=size_bytes)
    if (.not. exists) then
      msg = 'file not found: '//trim(path)
      return
    end if
    if (len_trim(not_regular(path)) > 0) then
      msg = what//trim(path)//' is '//trim(not_regular(path))
      if (not_regular(path) /= 'a directory') msg = trim(msg)//', not a regular file'
      return
    end if
    status = MLID_OK
    msg = ''
    if (present(by_line)) then
      if (by_line) size_bytes = 0
    end if
    if (size_bytes > 0) then
      open (newunit=unit, file=path, access='stream', form='unformatted', action='read', &
            status='old', iostat=status)
      if (status == 0) then
        allocate (character(len=size_bytes) :: tf%text)
        read (unit, iostat=status) tf%text
        close (unit)
        if (status == 0) return
        deallocate (tf%text)
      end if
    end if
    open (newunit=tf%unit, file=path, status='old', action='read', form='formatted', &
          access='sequential', iostat=status)
    if (status /= 0) then
      status = MLID_ERR_INPUT
      msg = what//trim(path)//': cannot be opened'
    end if
  end subroutine text_open

  !> The next line of any length (without its end, CR-LF or LF; a byte-order
  !> mark dropped on the first line); ios < 0 at the end of the file.
  subroutine text_line(tf, line, ios)
    type(text_file_t), intent(inout) :: tf
    character(len=:), allocatable, intent(out) :: line
    integer, intent(out) :: ios
    integer(int64) :: e
    integer :: n

    if (allocated(tf%text)) then
      ios = 0
      if (tf%pos > len(tf%text, int64)) then
        ios = -1
        line = ''
        return
      end if
      e = index(tf%text(tf%pos:), achar(10), kind=int64)
      if (e == 0) e = len(tf%text, int64) - tf%pos + 2
      line = tf%text(tf%pos:tf%pos + e - 2)
      tf%pos = tf%pos + e
    else
      call read_line(tf%unit, line, ios)
      if (ios /= 0) return
    end if
    n = len(line)
    if (n > 0) then
      if (line(n:n) == achar(13)) line = line(1:n - 1)
    end if
    if (tf%nline == 0 .and. len(line) >= 3) then
      if (line(1:3) == BOM) line = line(4:)
    end if
    tf%nline = tf%nline + 1
  end subroutine text_line

  subroutine text_close(tf)
    type(text_file_t), intent(inout) :: tf
    if (.not. allocated(tf%text)) close (tf%unit)
  end subroutine text_close

  !> One line of a formatted unit, of any length; ios < 0 at the end.
  subroutine read_line(unit, line, ios)
    integer, intent(in) :: unit
    character(len=:), allocatable, intent(out) :: line
    integer, intent(out) :: ios
    character(len=CHUNK) :: buf
    integer :: n
    line = ''
    do
      read (unit, '(a)', advance='no', size=n, iostat=ios) buf
      line = line//buf(1:n)
      if (ios /= 0) exit
    end do
    if (is_iostat_eor(ios)) ios = 0
    if (ios < 0 .and. len(line) > 0) ios = 0      ! a last line without its end
  end subroutine read_line

  !> The first control character of line (TAB is blank, not one), as
  !> '\xHH at character k' for a message: a NUL or a stray CR in a deck or
  !> a record would be read wrong or cut messages short; '' if none.
  function control_character(line, offset) result(text)
    character(len=*), intent(in) :: line
    integer, intent(in), optional :: offset    !< where line starts in the file's line, less 1
    character(len=:), allocatable :: text
    character(len=2) :: hex
    integer :: k, c, at
    text = ''
    at = 0
    if (present(offset)) at = offset
    do k = 1, len(line)
      c = iachar(line(k:k))
      if ((c >= 32 .and. c /= 127) .or. c == 9) cycle
      write (hex, '(z2.2)') c
      text = 'control character \x'//hex//' at character '//itoa(at + k)
      return
    end do
  end function control_character

  !> Where a deck line's comment starts: its first '!' outside quotes (a
  !> doubled quote inside quoted text toggles twice); len + 1 if none.
  pure integer function comment_start(line) result(k)
    character(len=*), intent(in) :: line
    character :: quote
    quote = ' '
    do k = 1, len(line)
      if (quote /= ' ') then
        if (line(k:k) == quote) quote = ' '
      else if (line(k:k) == '''' .or. line(k:k) == '"') then
        quote = line(k:k)
      else if (line(k:k) == '!') then
        return
      end if
    end do
    k = len(line) + 1
  end function comment_start

  !> All lines of a text file (a deck: its reader checks each case's text
  !> for control characters, so that one case's fails that case alone).
  subroutine read_text(path, lines, status, msg)
    character(len=*), intent(in) :: path
    type(line_t), allocatable, intent(out) :: lines(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(line_t), allocatable :: more(:)
    type(text_file_t) :: tf
    type(file_stamp_t) :: stamp
    integer :: ios, n

    allocate (lines(0))
    stamp = file_stamp(path)
    call text_open(path, '', tf, status, msg)
    if (status /= MLID_OK) return
    deallocate (lines)
    allocate (lines(64))
    n = 0
    do
      if (n == size(lines)) then
        allocate (more(2*n))
        more(1:n) = lines
        call move_alloc(more, lines)
      end if
      call text_line(tf, lines(n + 1)%s, ios)
      if (ios /= 0) exit
      n = n + 1
    end do
    call text_close(tf)
    lines = lines(1:n)
    if (ios > 0) then
      status = MLID_ERR_INPUT
      msg = trim(path)//': cannot be read'
    else
      msg = file_changed(path, stamp)
      if (len_trim(msg) > 0) status = MLID_ERR_INPUT
      if (len_trim(msg) > 0) msg = trim(path)//' '//trim(msg)
    end if
  end subroutine read_text

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
      text = trim(adjustl(es_text(x, 10, 3)))
    end if
  end function number_text

  !> x as the edit descriptor ESw.dE2 writes it (a report's column), or,
  !> when that field would be asterisks, in the fewest characters (at least
  !> w, right-justified) that hold it: ES with a two-digit exponent (a sign
  !> the width had no room for), else with a three-digit one ('1.0000E+150':
  !> |x| from about 1E+100, or non-zero below 1E-99).  A normal number keeps
  !> its bytes; none becomes asterisks.
  function es_text(x, w, d) result(text)
    real(wp), intent(in) :: x
    integer, intent(in) :: w, d
    character(len=:), allocatable :: text
    character(len=64) :: buf
    write (buf, '(es'//itoa(w)//'.'//itoa(d)//'e2)') x
    if (index(buf(1:w), '*') == 0) then
      text = buf(1:w)
      return
    end if
    write (buf, '(es'//itoa(d + 7)//'.'//itoa(d)//'e2)') x      ! sign, digit, point, E+nn
    if (index(buf(1:d + 7), '*') > 0) write (buf, '(es'//itoa(d + 8)//'.'//itoa(d)//'e3)') x
    text = trim(adjustl(buf))
    if (len(text) < w) text = repeat(' ', w - len(text))//text
  end function es_text

  !> x as Fw.d writes it, or es_text(x, w, d) when that would be asterisks
  !> (a value too large for the column).
  function fixed_text(x, w, d) result(text)
    real(wp), intent(in) :: x
    integer, intent(in) :: w, d
    character(len=:), allocatable :: text
    character(len=64) :: buf
    write (buf, '(f'//itoa(w)//'.'//itoa(d)//')') x
    text = buf(1:w)
    if (index(text, '*') > 0) text = es_text(x, w, max(1, min(d, w - 7)))
  end function fixed_text

  !> lines with text appended; grown by hand (an array constructor of
  !> line_t loses the lengths with gfortran 12).
  subroutine add_line(lines, text)
    type(line_t), allocatable, intent(inout) :: lines(:)
    character(len=*), intent(in) :: text
    type(line_t), allocatable :: more(:)
    integer :: j
    if (.not. allocated(lines)) allocate (lines(0))
    allocate (more(size(lines) + 1))
    do j = 1, size(lines)
      call move_alloc(lines(j)%s, more(j)%s)
    end do
    more(size(more))%s = trim(text)
    call move_alloc(more, lines)
  end subroutine add_line

end module mlid_text
