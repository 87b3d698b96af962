!> Small text helpers shared by the readers and the flat interface, and
!> the opening and reading of text files of any line length.
module mlid_text
  use mlid_kinds, only: MLID_OK, MLID_ERR_INPUT
  implicit none
  private
  public :: to_lower, itoa, joined, join_lines, split_lines, open_text, read_line, read_text, &
            line_t

  integer, parameter :: CHUNK = 4096
  character(len=3), parameter :: BOM = char(239)//char(187)//char(191)   !< UTF-8 byte-order mark

  !> One line of text (gfortran mishandles arrays of deferred-length
  !> character as components; an array of these does not).
  type :: line_t
    character(len=:), allocatable :: s
  end type line_t

contains

  pure function to_lower(s) result(r)
    character(len=*), intent(in) :: s
    character(len=len(s)) :: r
    integer :: k
    r = s
    do k = 1, len(s)
      if (s(k:k) >= 'A' .and. s(k:k) <= 'Z') r(k:k) = achar(iachar(s(k:k)) + 32)
    end do
  end function to_lower

  function itoa(i) result(s)
    integer, intent(in) :: i
    character(len=:), allocatable :: s
    character(len=16) :: buf
    write (buf, '(i0)') i
    s = trim(buf)
  end function itoa

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

  !> Open a text file to read; a missing file or a directory is refused.
  subroutine open_text(path, what, unit, status, msg)
    character(len=*), intent(in) :: path, what
    integer, intent(out) :: unit, status
    character(len=*), intent(out) :: msg
    logical :: exists
    status = MLID_ERR_INPUT
    unit = -1
    inquire (file=path, exist=exists)
    if (.not. exists) then
      msg = 'file not found: '//trim(path)
      return
    end if
    inquire (file=trim(path)//'/.', exist=exists)
    if (exists) then
      msg = what//trim(path)//' is a directory'
      return
    end if
    open (newunit=unit, file=path, status='old', action='read', form='formatted', &
          access='sequential', iostat=status)
    if (status /= 0) then
      status = MLID_ERR_INPUT
      msg = what//trim(path)//': cannot be opened'
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine open_text

  !> One line of any length (without its end, CR-LF or LF; a byte-order
  !> mark dropped on the first line); ios < 0 at the end of the file.
  subroutine read_line(unit, first, line, ios)
    integer, intent(in) :: unit
    logical, intent(in) :: first
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
    n = len(line)
    if (n > 0) then
      if (line(n:n) == achar(13)) line = line(1:n - 1)
    end if
    if (first .and. len(line) >= 3) then
      if (line(1:3) == BOM) line = line(4:)
    end if
  end subroutine read_line

  !> All lines of a text file.
  subroutine read_text(path, lines, status, msg)
    character(len=*), intent(in) :: path
    type(line_t), allocatable, intent(out) :: lines(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(line_t), allocatable :: more(:)
    integer :: unit, ios, n

    allocate (lines(0))
    call open_text(path, '', unit, status, msg)
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
      call read_line(unit, n == 0, lines(n + 1)%s, ios)
      if (ios /= 0) exit
      n = n + 1
    end do
    close (unit)
    lines = lines(1:n)
    if (ios > 0) then
      status = MLID_ERR_INPUT
      msg = trim(path)//': cannot be read'
    end if
  end subroutine read_text

end module mlid_text
