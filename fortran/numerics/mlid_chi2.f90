!> The chi-square distribution's upper tail and its quantile: the
!> consistency tests' p-values and limits (the two-step table fit,
!> mlid_table_fit).  The tail is the regularized upper incomplete gamma
!> function Q(k/2, x/2): its power series below x/2 = k/2 + 1, its
!> continued fraction (evaluated by the modified Lentz method) above.
module mlid_chi2
  use mlid_kinds, only: wp
  implicit none
  private
  public :: chi2_sf, chi2_limit

  integer, parameter :: MAXTERMS = 1000

contains

  !> P(X > x) for X chi-square with k degrees of freedom (k >= 1); 1 for
  !> x <= 0.
  pure real(wp) function chi2_sf(x, k) result(q)
    real(wp), intent(in) :: x
    integer, intent(in) :: k
    real(wp) :: a, h
    q = 1.0_wp
    if (x <= 0.0_wp .or. k < 1) return
    a = 0.5_wp*k
    h = 0.5_wp*x
    if (h < a + 1.0_wp) then
      q = 1.0_wp - lower_series(a, h)
    else
      q = upper_fraction(a, h)
    end if
    q = min(1.0_wp, max(0.0_wp, q))
  end function chi2_sf

  !> The regularized lower incomplete gamma P(a, h) by its series
  !> e^-h h^a / Gamma(a) sum_n h^n / (a (a+1) .. (a+n)).
  pure real(wp) function lower_series(a, h) result(p)
    real(wp), intent(in) :: a, h
    real(wp) :: term, total, ap
    integer :: n
    ap = a
    term = 1.0_wp/a
    total = term
    do n = 1, MAXTERMS
      ap = ap + 1.0_wp
      term = term*h/ap
      total = total + term
      if (abs(term) < abs(total)*epsilon(1.0_wp)) exit
    end do
    p = total*exp(-h + a*log(h) - log_gamma(a))
  end function lower_series

  !> The regularized upper incomplete gamma Q(a, h) by its continued
  !> fraction 1/(h+1-a - 1(1-a)/(h+3-a - 2(2-a)/(h+5-a - ...))) times
  !> e^-h h^a / Gamma(a) (modified Lentz).
  pure real(wp) function upper_fraction(a, h) result(q)
    real(wp), intent(in) :: a, h
    real(wp), parameter :: TINY = 1.0e-300_wp
    real(wp) :: b, c, d, f, an, step
    integer :: i
    b = h + 1.0_wp - a
    c = 1.0_wp/TINY
    d = 1.0_wp/b
    f = d
    do i = 1, MAXTERMS
      an = -i*(i - a)
      b = b + 2.0_wp
      d = an*d + b
      if (abs(d) < TINY) d = TINY
      c = b + an/c
      if (abs(c) < TINY) c = TINY
      d = 1.0_wp/d
      step = d*c
      f = f*step
      if (abs(step - 1.0_wp) < epsilon(1.0_wp)) exit
    end do
    q = f*exp(-h + a*log(h) - log_gamma(a))
  end function upper_fraction

  !> The x with chi2_sf(x, k) = level (0 < level < 1): the value a
  !> chi-square of k degrees of freedom passes with probability level, by
  !> bisection on a bracket grown until it holds it.
  pure real(wp) function chi2_limit(level, k) result(x)
    real(wp), intent(in) :: level
    integer, intent(in) :: k
    real(wp) :: lo, hi
    integer :: i
    x = 0.0_wp
    if (k < 1 .or. .not. (level > 0.0_wp .and. level < 1.0_wp)) return
    lo = 0.0_wp
    hi = k + 10.0_wp*sqrt(2.0_wp*k) + 10.0_wp
    do i = 1, 60
      if (chi2_sf(hi, k) <= level) exit
      lo = hi
      hi = 2.0_wp*hi
    end do
    do i = 1, 200
      x = 0.5_wp*(lo + hi)
      if (chi2_sf(x, k) > level) then
        lo = x
      else
        hi = x
      end if
      if (hi - lo <= 4.0_wp*epsilon(1.0_wp)*hi) exit
    end do
    x = 0.5_wp*(lo + hi)
  end function chi2_limit

end module mlid_chi2
