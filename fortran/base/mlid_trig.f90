!> The sine and cosine of one angle together, for the models' points.
!>
!> On 2^-26 <= |x| <= pi/4, the angles a flight record's attitude and
!> flow angles take, Taylor polynomials through x^17 (sine) and x^16
!> (cosine), whose truncation is below 1e-17 there (x^19/19!, x^18/18!):
!> within one unit in the last place of the intrinsics
!> (tests/fortran/test_trig.f90), at a fraction of a library call's cost,
!> and the same bits whatever the libm (for a given build: a native one may
!> fuse multiply-adds).  Elsewhere (beyond pi/4, below 2^-26, a NaN or an
!> infinity) the intrinsics.
module mlid_trig
  use mlid_kinds, only: wp
  implicit none
  private
  public :: sin_cos, TRIG_POLY_MAX

  !> Where the polynomials end: pi/4 (rounded down); below 2^-26 (and at
  !> the signed zeros) the intrinsics, whose sine there is x itself.
  real(wp), parameter :: TRIG_POLY_MAX = 0.785398163397448_wp, TRIG_POLY_MIN = 2.0_wp**(-26)
  !> (-1)^k/(2k+1)! and (-1)^k/(2k)!, k = 1.. (folded by the compiler)
  real(wp), parameter :: S1 = -1.0_wp/6.0_wp, S2 = 1.0_wp/120.0_wp, S3 = -1.0_wp/5040.0_wp, &
                         S4 = 1.0_wp/362880.0_wp, S5 = -1.0_wp/39916800.0_wp, &
                         S6 = 1.0_wp/6227020800.0_wp, S7 = -1.0_wp/1307674368000.0_wp, &
                         S8 = 1.0_wp/355687428096000.0_wp
  real(wp), parameter :: C2 = 1.0_wp/24.0_wp, C3 = -1.0_wp/720.0_wp, C4 = 1.0_wp/40320.0_wp, &
                         C5 = -1.0_wp/3628800.0_wp, C6 = 1.0_wp/479001600.0_wp, &
                         C7 = -1.0_wp/87178291200.0_wp, C8 = 1.0_wp/20922789888000.0_wp

contains

  !> s = sin(x), c = cos(x).
  elemental subroutine sin_cos(x, s, c)
    real(wp), intent(in) :: x
    real(wp), intent(out) :: s, c
    real(wp) :: z, z2, z4
    if (.not. (abs(x) <= TRIG_POLY_MAX .and. abs(x) >= TRIG_POLY_MIN)) then
      s = sin(x)
      c = cos(x)
      return
    end if
    ! Estrin's scheme (pairs, then pairs of pairs): a quarter of Horner's
    ! chain of dependent multiply-adds, which the model's next stage waits on
    z = x*x
    z2 = z*z
    z4 = z2*z2
    s = x + x*z*(((S1 + S2*z) + (S3 + S4*z)*z2) + ((S5 + S6*z) + (S7 + S8*z)*z2)*z4)
    c = 1.0_wp - 0.5_wp*z + z2*(((C2 + C3*z) + (C4 + C5*z)*z2) + ((C6 + C7*z) + C8*z2)*z4)
  end subroutine sin_cos

end module mlid_trig
