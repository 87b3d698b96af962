!> What the Fortran unit tests share: a named check that counts failures,
!> and the end that reports them (a failing test program exits non-zero).
module test_checks
  implicit none
  private
  public :: check, finish, failures

  integer :: nfail = 0

contains

  subroutine check(ok, what)
    logical, intent(in) :: ok
    character(len=*), intent(in) :: what
    if (.not. ok) then
      nfail = nfail + 1
      write (*, '(a)') 'FAIL: '//what
    else
      write (*, '(a)') 'ok:   '//what
    end if
  end subroutine check

  integer function failures()
    failures = nfail
  end function failures

  subroutine finish()
    if (nfail > 0) then
      write (*, '(i0,a)') nfail, ' checks failed'
      error stop 1
    end if
    write (*, '(a)') 'all checks passed'
  end subroutine finish

end module test_checks
