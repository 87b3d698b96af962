!> mlid_tables through the equations model: at the breakpoints the values
!> themselves and weights of exactly 0 and 1; the slope with respect to a
!> variable that of the cell to the right of a breakpoint (a configuration
!> flag on 0 or 1 is in the cell it starts), zero beyond the ends; the
!> smoothness weight the second differences' D'D.
program test_tables
  use mlid_kinds, only: wp, MLID_OK
  use mlid_equations, only: equations_t, equations_create, equations_text_codes, &
                            equations_tables
  use test_checks, only: check, finish
  implicit none
  character(len=*), parameter :: TEXT = 'u a'//achar(10)//'u f'//achar(10)// &
    't T(a, f) = 0 0.1 0.3; 0 1'//achar(10)//'y y = T'
  type(equations_t) :: m
  real(wp) :: p(6), x(0), y(1), d(1, 6), du(1, 2), w(6, 6), want(6, 6)
  character(len=160) :: texts(6)
  character(len=256) :: msg
  integer :: st, k

  call equations_create(equations_text_codes(TEXT), [real(wp) ::], m, st, msg)
  call check(st == MLID_OK .and. m%np == 6, 'a table over (a, f): 3 x 2 values')
  call check(all(m%pnames == [character(len=32) :: 'T[1,1]', 'T[2,1]', 'T[3,1]', 'T[1,2]', &
                              'T[2,2]', 'T[3,2]']), 'the values named T[i,j], i fastest')
  p = [1.0_wp, 2.0_wp, 5.0_wp, -1.0_wp, 0.5_wp, 4.0_wp]
  call at([0.1_wp, 0.0_wp])
  call check(y(1) == p(2) .and. all(d(1, :) == [0, 1, 0, 0, 0, 0]), &
             'on the breakpoints (0.1, 0): the value itself, weights exactly 0 and 1')
  call check(abs(du(1, 1) - (p(3) - p(2))/0.2_wp) < 1e-12_wp .and. &
             abs(du(1, 2) - (p(5) - p(2))) < 1e-12_wp, &
             'on a breakpoint: the slope of the cell to its right, in each variable')
  call at([0.3_wp, 1.0_wp])
  call check(y(1) == p(6) .and. all(du(1, :) == 0), 'on the last breakpoints: held, slope 0')
  call at([-0.5_wp, 0.5_wp])
  call check(abs(y(1) - 0.5_wp*(p(1) + p(4))) < 1e-15_wp .and. du(1, 1) == 0 .and. &
             abs(du(1, 2) - (p(4) - p(1))) < 1e-12_wp, 'below the first breakpoint: held')
  call at([0.2_wp, 0.25_wp])
  call check(abs(sum(d(1, :)) - 1) < 1e-15_wp .and. abs(y(1) - dot_product(d(1, :), p)) < &
             1e-14_wp, 'inside a cell: weights summing to 1, the value their sum with p')
  call equations_tables(m, [2.0_wp], texts, w, st, msg)
  want = 0                    ! one second difference along a: (1/0.1, -(1/0.1 + 1/0.2), 1/0.2)
  do k = 0, 3, 3              !   times the mean spacing 0.15, in each column of f
    want(k + 1:k + 3, k + 1:k + 3) = 2*spread([1.5_wp, -2.25_wp, 0.75_wp], 1, 3)* &
                                     spread([1.5_wp, -2.25_wp, 0.75_wp], 2, 3)
  end do
  call check(st == MLID_OK .and. maxval(abs(w - want)) < 1e-12_wp, &
             'the smoothness weight: lambda D''D of the second differences along a')
  call check(trim(texts(5)) == 'T[2,2] (a = 0.1, f = 1; weighted where 0 < a < 0.3, 0 < f)', &
             'a value''s text says where it is weighted')
  call finish()

contains

  subroutine at(u)
    real(wp), intent(in) :: u(2)
    call m%eval(0.0_wp, x, u, p, [1, 2, 3, 4, 5, 6], y=y, d=d)
    call m%dhdu(0.0_wp, x, u, p, du)
  end subroutine at

end program test_tables
