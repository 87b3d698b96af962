!> Small text helpers shared by the readers and the flat interface.
module mlid_text
  implicit none
  private
  public :: to_lower, itoa, joined, join_lines, split_lines

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

end module mlid_text
