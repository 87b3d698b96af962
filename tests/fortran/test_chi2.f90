!> mlid_chi2 against the closed forms: two degrees of freedom, P(X > x) =
!> exp(-x/2) (the continued fraction's side far out, 1e-217); one, erfc(sqrt(x/2))
!> (the series' side and the fraction's); four, (1 + x/2) exp(-x/2); the limit
!> their inverse; no degrees of freedom or x <= 0: 1.
program test_chi2
  use mlid_kinds, only: wp
  use mlid_chi2, only: chi2_sf, chi2_limit
  use test_checks, only: check, finish
  implicit none
  real(wp) :: x(7) = [0.01_wp, 0.5_wp, 1.9_wp, 3.0_wp, 12.0_wp, 80.0_wp, 1000.0_wp]
  real(wp) :: err2, err1, err4
  integer :: i

  err2 = 0
  err1 = 0
  err4 = 0
  do i = 1, size(x)
    err2 = max(err2, abs(chi2_sf(x(i), 2)/exp(-x(i)/2) - 1))
    err4 = max(err4, abs(chi2_sf(x(i), 4)/((1 + x(i)/2)*exp(-x(i)/2)) - 1))
    if (x(i) < 1000) err1 = max(err1, abs(chi2_sf(x(i), 1)/erfc(sqrt(x(i)/2)) - 1))
  end do
  call check(err2 < 1e-13_wp, 'two degrees of freedom: exp(-x/2), x from 0.01 to 1000')
  call check(err1 < 1e-12_wp, 'one degree of freedom: erfc(sqrt(x/2)), x from 0.01 to 80')
  call check(err4 < 1e-13_wp, 'four degrees of freedom: (1 + x/2) exp(-x/2)')
  call check(abs(chi2_limit(0.01_wp, 2) + 2*log(0.01_wp)) < 1e-12_wp, &
             'the limit at 0.01 of two degrees of freedom: -2 ln 0.01')
  call check(abs(chi2_limit(0.05_wp, 1) - 3.841458820694124_wp) < 1e-11_wp, &
             'the limit at 0.05 of one degree of freedom: 1.96^2')
  call check(chi2_sf(0.0_wp, 3) == 1 .and. chi2_sf(-1.0_wp, 3) == 1 .and. chi2_sf(5.0_wp, 0) == 1 &
             .and. chi2_limit(0.5_wp, 0) == 0, 'nothing to test: 1, and limit 0')
  call finish()
end program test_chi2
