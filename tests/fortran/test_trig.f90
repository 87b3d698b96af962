!> mlid_trig's sin_cos against the intrinsics: within one unit in the last
!> place on the polynomials' range (a dense grid, its ends, random points,
!> tiny angles and the signed zeros), the intrinsics' own bits beyond it and
!> for NaN and infinities.
program test_trig
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf, &
                                           ieee_is_nan
  use mlid_kinds, only: wp
  use mlid_trig, only: sin_cos, TRIG_POLY_MAX
  use test_checks, only: check, finish
  implicit none
  integer, parameter :: NGRID = 200001
  real(wp) :: x(NGRID + 1000), s, c, worst, nan, inf
  integer :: i

  do i = 1, NGRID                    ! -pi/4 .. pi/4, both ends included
    x(i) = TRIG_POLY_MAX*(2*real(i - 1, wp)/(NGRID - 1) - 1)
  end do
  call random_seed(put=[(12345 + i, i = 1, 64)])
  call random_number(x(NGRID + 1:))
  x(NGRID + 1:) = TRIG_POLY_MAX*(2*x(NGRID + 1:) - 1)
  worst = 0
  do i = 1, size(x)
    worst = max(worst, ulps(x(i)))
  end do
  write (*, '(a,f5.2)') 'largest difference on [-pi/4, pi/4], in units in the last place: ', worst
  call check(worst <= 1.0_wp, 'within one unit in the last place of the intrinsics on [-pi/4, pi/4]')
  call check(ulps(1.0e-9_wp) == 0 .and. ulps(-3.0e-200_wp) == 0, 'tiny angles: the intrinsics'' bits')
  call sin_cos(0.0_wp, s, c)
  call check(s == 0 .and. .not. sign(1.0_wp, s) < 0 .and. c == 1, 'sin_cos(+0) = (+0, 1)')
  call sin_cos(-0.0_wp, s, c)
  call check(s == 0 .and. sign(1.0_wp, s) < 0 .and. c == 1, 'sin_cos(-0) = (-0, 1)')
  call check(beyond(nearest(TRIG_POLY_MAX, 1.0_wp)) .and. beyond(-1.0_wp) .and. beyond(3.0_wp) &
             .and. beyond(-1.0e5_wp), 'beyond pi/4: the intrinsics to the bit')
  nan = ieee_value(1.0_wp, ieee_quiet_nan)
  inf = ieee_value(1.0_wp, ieee_positive_inf)
  call sin_cos(nan, s, c)
  call check(ieee_is_nan(s) .and. ieee_is_nan(c), 'NaN gives NaN')
  call sin_cos(inf, s, c)
  call check(ieee_is_nan(s) .and. ieee_is_nan(c), 'an infinity gives NaN')
  call finish()

contains

  !> The larger of sin_cos's differences from sin and cos at x, in units in
  !> the last place of the intrinsics' values.
  real(wp) function ulps(x)
    real(wp), intent(in) :: x
    real(wp) :: s, c
    call sin_cos(x, s, c)
    ulps = max(abs(s - sin(x))/spacing(sin(x)), abs(c - cos(x))/spacing(cos(x)))
  end function ulps

  logical function beyond(x)
    real(wp), intent(in) :: x
    real(wp) :: s, c
    call sin_cos(x, s, c)
    beyond = s == sin(x) .and. c == cos(x)
  end function beyond

end program test_trig
