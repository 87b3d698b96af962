!> Seeded pseudo-random numbers: L'Ecuyer's MRG32k3a with Box-Muller
!> normals.
!>
!> MRG32k3a needs only products below 2**53, so it runs exactly in 64-bit
!> integers with no overflow and gives the same stream on every compiler,
!> which the seeded tests and cases rely on.
module mlid_random
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp
  implicit none
  private
  public :: rng_t, rng_seed, rng_uniform, rng_normal

  integer(int64), parameter :: m1 = 4294967087_int64, m2 = 4294944443_int64
  integer(int64), parameter :: a12 = 1403580_int64, a13n = 810728_int64
  integer(int64), parameter :: a21 = 527612_int64, a23n = 1370589_int64
  real(wp), parameter :: norm = 1.0_wp/real(m1 + 1_int64, wp)

  type :: rng_t
    integer(int64) :: s1(3) = [12345_int64, 12345_int64, 12345_int64]
    integer(int64) :: s2(3) = [12345_int64, 12345_int64, 12345_int64]
    logical :: have_spare = .false.
    real(wp) :: spare = 0.0_wp
  end type rng_t

contains

  !> Start a stream from a non-negative integer seed.
  subroutine rng_seed(rng, seed)
    type(rng_t), intent(out) :: rng
    integer, intent(in) :: seed
    integer(int64) :: x
    integer :: i
    real(wp) :: discard

    ! A 32-bit LCG spreads the seed over the six state words.
    x = modulo(int(seed, int64), 4294967296_int64)
    do i = 1, 3
      x = modulo(69069_int64*x + 1_int64, 4294967296_int64)
      rng%s1(i) = modulo(x, m1)
      x = modulo(69069_int64*x + 1_int64, 4294967296_int64)
      rng%s2(i) = modulo(x, m2)
    end do
    if (all(rng%s1 == 0)) rng%s1(1) = 1
    if (all(rng%s2 == 0)) rng%s2(1) = 1
    rng%have_spare = .false.
    ! Discard the first draws so that neighbouring seeds decorrelate.
    do i = 1, 16
      discard = rng_uniform(rng)
    end do
  end subroutine rng_seed

  !> Uniform deviate in (0, 1).
  function rng_uniform(rng) result(r)
    type(rng_t), intent(inout) :: rng
    real(wp) :: r
    integer(int64) :: p1, p2

    p1 = modulo(a12*rng%s1(2) - a13n*rng%s1(1), m1)
    rng%s1 = [rng%s1(2), rng%s1(3), p1]
    p2 = modulo(a21*rng%s2(3) - a23n*rng%s2(1), m2)
    rng%s2 = [rng%s2(2), rng%s2(3), p2]
    if (p1 <= p2) then
      r = real(p1 - p2 + m1, wp)*norm
    else
      r = real(p1 - p2, wp)*norm
    end if
  end function rng_uniform

  !> Standard normal deviate (Box-Muller, both values used).
  function rng_normal(rng) result(z)
    type(rng_t), intent(inout) :: rng
    real(wp) :: z
    real(wp) :: u1, u2, rad
    real(wp), parameter :: two_pi = 6.283185307179586476925286766559_wp

    if (rng%have_spare) then
      rng%have_spare = .false.
      z = rng%spare
      return
    end if
    u1 = rng_uniform(rng)
    u2 = rng_uniform(rng)
    rad = sqrt(-2.0_wp*log(u1))
    z = rad*cos(two_pi*u2)
    rng%spare = rad*sin(two_pi*u2)
    rng%have_spare = .true.
  end function rng_normal

end module mlid_random
