!> Local smoothing and differentiation of one uniformly sampled channel by
!> fixed symmetric formulas, the classical alternative to the global Fourier
!> smoother (mlid_smooth).  The windows and the rules at the ends are those
!> of the textbook's preprocessing (Jategaonkar, Flight Vehicle System
!> Identification, 2nd ed., sec. 2.5, eqs 2.13-2.14; FVSysID's ndiff_pqr),
!> so that a deck reproduces its angular accelerations from the raw rates;
!> own code.  i below is the number of samples on the shorter side of a
!> sample (0 at the first and the last).
!>
!> smooth_local: Spencer's 15-point moving average (weights -3 -6 -5 3 21 46
!>   67 74 ... /320, exact for cubics) where i >= 8; the 5-point weights
!>   (7 24 34 24 7)/96 where 3 <= i <= 7; the sample itself where i <= 2.
!> deriv_local: the central difference of smooth_local's output, on 17
!>   points (exact for polynomials of degree 16) where i >= 9, on 5 points
!>   where 2 <= i <= 8; the two samples at each end take the value of the
!>   third (held: no one-sided formula).
!>
!> The held ends make the integral of the derivative over the record differ
!> from the change of the channel; the Fourier deriv has no such error
!> (docs: the guide's decks page).
module mlid_local_smooth
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_MEMORY
  use mlid_text, only: itoa
  implicit none
  private
  public :: smooth_local, deriv_local, LOCAL_MIN_SAMPLES, LOCAL_NO_CUTOFF

  !> The 5-point derivative needs two samples each side of the third.
  integer, parameter :: LOCAL_MIN_SAMPLES = 5
  !> Why a cut-off given to the local smoother is refused.
  character(len=*), parameter :: LOCAL_NO_CUTOFF = 'the local smoother takes no cut-off: its '// &
                                                   'windows are fixed'
  real(wp), parameter :: SPENCER(0:7) = [74.0_wp, 67.0_wp, 46.0_wp, 21.0_wp, 3.0_wp, &
                                         -5.0_wp, -6.0_wp, -3.0_wp]/320.0_wp
  real(wp), parameter :: FIVE(0:2) = [34.0_wp, 24.0_wp, 7.0_wp]/96.0_wp

contains

  !> xs: x smoothed by the rule above; status/msg: too few samples.
  subroutine smooth_local(x, xs, status, msg)
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: xs(size(x))
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: n, k, i
    n = size(x)
    xs = x
    call enough(n, status, msg)
    if (status /= MLID_OK) return
    do k = 1, n
      i = min(k - 1, n - k)
      if (i >= 8) then
        xs(k) = symmetric(x, k, SPENCER)
      else if (i >= 3) then
        xs(k) = symmetric(x, k, FIVE)
      end if
    end do
  end subroutine smooth_local

  !> xd: the derivative of smooth_local(x) at step dt by the rule above.
  subroutine deriv_local(x, dt, xd, status, msg)
    real(wp), intent(in) :: x(:), dt
    real(wp), intent(out) :: xd(size(x))
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: xs(:)
    real(wp) :: c17(8), c5(2)
    integer :: n, k, i, ierr
    n = size(x)
    xd = 0.0_wp
    if (.not. dt > 0.0_wp) then
      status = MLID_ERR_INPUT
      msg = 'differentiation needs a time step > 0'
      return
    end if
    allocate (xs(n), stat=ierr)            ! heap: decks are read in small threads
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'local smoothing: out of memory'
      return
    end if
    call smooth_local(x, xs, status, msg)
    if (status /= MLID_OK) return
    c17 = central_weights(8)
    c5 = central_weights(2)
    do k = 1, n
      i = min(k - 1, n - k)
      if (i >= 9) then
        xd(k) = antisymmetric(xs, k, c17)/dt
      else if (i >= 2) then
        xd(k) = antisymmetric(xs, k, c5)/dt
      end if
    end do
    xd(1:2) = xd(3)
    xd(n - 1:n) = xd(n - 2)
  end subroutine deriv_local

  subroutine enough(n, status, msg)
    integer, intent(in) :: n
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    status = MLID_OK
    msg = ''
    if (n >= LOCAL_MIN_SAMPLES) return
    status = MLID_ERR_INPUT
    msg = 'local smoothing needs at least '//itoa(LOCAL_MIN_SAMPLES)//' samples, '// &
          itoa(n)//' given'
  end subroutine enough

  !> sum_j w(|j|) x(k + j), j = -m .. m (m = ubound(w)).
  pure real(wp) function symmetric(x, k, w) result(s)
    real(wp), intent(in) :: x(:), w(0:)
    integer, intent(in) :: k
    integer :: j
    s = w(0)*x(k)
    do j = 1, ubound(w, 1)
      s = s + w(j)*(x(k + j) + x(k - j))
    end do
  end function symmetric

  !> sum_j c(j) (x(k + j) - x(k - j)), j = 1 .. size(c).
  pure real(wp) function antisymmetric(x, k, c) result(s)
    real(wp), intent(in) :: x(:), c(:)
    integer, intent(in) :: k
    integer :: j
    s = 0.0_wp
    do j = 1, size(c)
      s = s + c(j)*(x(k + j) - x(k - j))
    end do
  end function antisymmetric

  !> The weights of the central difference on 2m + 1 points (the derivative
  !> of the interpolating polynomial at the middle):
  !> c(j) = (-1)^(j+1) (m!)^2 / (j (m-j)! (m+j)!), as a running product.
  pure function central_weights(m) result(c)
    integer, intent(in) :: m
    real(wp) :: c(m), r
    integer :: j
    r = 1.0_wp                               ! (m!)^2 / ((m-j)! (m+j)!) at j
    do j = 1, m
      r = r*real(m - j + 1, wp)/real(m + j, wp)
      c(j) = merge(1.0_wp, -1.0_wp, mod(j, 2) == 1)*r/j
    end do
  end function central_weights

end module mlid_local_smooth
