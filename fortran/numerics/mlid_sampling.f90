!> The time grid of a record: time increases, has no gap (two manoeuvres
!> joined), and, for the Fourier transforms, has equal steps.  Asked by the
!> record readers and by every estimator that takes a record's time.
module mlid_sampling
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: itoa, seconds, es_text
  implicit none
  private
  public :: record_check_time, record_check_segments, record_uniform_step, record_common_step, &
            median, GAP_FACTOR, UNIFORM_TOL

  !> A time step larger than this times the median step is a gap.
  real(wp), parameter :: GAP_FACTOR = 1.5_wp
  !> Uniform sampling: every step within this fraction of the mean step (the
  !> Fourier transforms, mlid_fourier's and mlid_fft's, take equal steps).
  real(wp), parameter :: UNIFORM_TOL = 1.0e-6_wp

contains

  !> Time must increase, and a step larger than GAP_FACTOR times the median
  !> step is a gap: two manoeuvres joined.  at: the sample where it happens.
  subroutine record_check_time(t, at, status, msg)
    real(wp), intent(in) :: t(:)
    integer, intent(out) :: at, status
    character(len=*), intent(out) :: msg
    real(wp) :: dt(max(size(t) - 1, 0)), med
    integer :: k

    status = MLID_OK
    msg = ''
    at = 0
    do k = 2, size(t)
      if (.not. t(k) > t(k - 1)) then
        status = MLID_ERR_INPUT
        at = k
        msg = 'time does not increase: '//seconds(t(k))//' after '//seconds(t(k - 1))// &
              ' (sample '//itoa(k)//')'
        return
      end if
    end do
    if (size(t) < 3) return
    dt = t(2:) - t(:size(t) - 1)
    med = median(dt)
    do k = 1, size(dt)
      if (dt(k) > GAP_FACTOR*med) then
        status = MLID_ERR_INPUT
        at = k + 1
        msg = 'a gap in time from '//seconds(t(k))//' to '//seconds(t(k + 1))//' at sample '// &
              itoa(k + 1)//' (sampling '//seconds(med)//'): split the record into manoeuvres '// &
              '(several files, or windows t_start/t_end of one)'
        return
      end if
    end do
  end subroutine record_check_time

  !> record_check_time for each manoeuvre of a joined record (segstart:
  !> the first sample of each); the message names the manoeuvre.
  subroutine record_check_segments(t, segstart, status, msg)
    real(wp), intent(in) :: t(:)
    integer, intent(in) :: segstart(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, first, last, at
    status = MLID_OK
    msg = ''
    do k = 1, size(segstart)
      call manoeuvre_bounds(segstart, k, size(t), first, last)
      if (last <= first) cycle
      call record_check_time(t(first:last), at, status, msg)
      if (status /= MLID_OK) then
        if (size(segstart) > 1) msg = 'manoeuvre '//itoa(k)//': '//trim(msg)
        msg = 'data: '//trim(msg)
        return
      end if
    end do
  end subroutine record_check_segments

  !> dt, the mean step of t, when t is uniformly sampled (every step within
  !> UNIFORM_TOL of dt): what the frequency-domain tools take.  Else a
  !> message naming the sample whose step is farthest from dt.
  subroutine record_uniform_step(t, dt, status, msg)
    real(wp), intent(in) :: t(:)
    real(wp), intent(out) :: dt
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: n, k
    n = size(t)
    dt = 0.0_wp
    status = MLID_ERR_INPUT
    if (n < 2) then
      msg = 'a record to transform needs at least two samples'
      return
    else if (.not. all(ieee_is_finite(t))) then
      msg = 'time is not finite at sample '//itoa(findloc(ieee_is_finite(t), .false., 1))
      return
    end if
    dt = (t(n) - t(1))/(n - 1)
    if (.not. dt > 0.0_wp) then
      msg = 'time must increase over a record to transform'
      return
    end if
    k = maxloc(abs(t(2:) - t(:n - 1) - dt), 1)
    if (abs(t(k + 1) - t(k) - dt) > UNIFORM_TOL*dt) then
      msg = 'time is not uniformly sampled: the step to sample '//itoa(k + 1)//' (t = '// &
            seconds(t(k + 1))//') is '//precise(t(k + 1) - t(k))//' s, the mean step '// &
            precise(dt)//' s (the frequency-domain tools need equal steps, to 1e-6 of the mean)'
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine record_uniform_step

  !> A step for a message, to the digits that UNIFORM_TOL tells apart.
  function precise(x) result(text)
    real(wp), intent(in) :: x
    character(len=:), allocatable :: text
    text = trim(adjustl(es_text(x, 16, 9)))
  end function precise

  !> The one step dt of the manoeuvres of t starting at samples starts: each
  !> uniformly sampled (record_uniform_step), all at the first's step to
  !> UNIFORM_TOL; the message names the manoeuvre when there are several.
  subroutine record_common_step(t, starts, dt, status, msg)
    real(wp), intent(in) :: t(:)
    integer, intent(in) :: starts(:)
    real(wp), intent(out) :: dt
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: d
    integer :: k, j0, j1
    dt = 0.0_wp
    status = MLID_ERR_INPUT
    msg = 'a record to transform needs at least two samples'
    do k = 1, size(starts)
      call manoeuvre_bounds(starts, k, size(t), j0, j1)
      call record_uniform_step(t(j0:j1), d, status, msg)
      if (status == MLID_OK .and. k > 1 .and. .not. abs(d - dt) <= UNIFORM_TOL*dt) then
        status = MLID_ERR_INPUT
        msg = 'its step '//precise(d)//' s is not manoeuvre 1''s '//precise(dt)// &
              ' s: the manoeuvres of a frequency response need one sampling interval'
      end if
      if (status /= MLID_OK) then
        if (size(starts) > 1) msg = 'manoeuvre '//itoa(k)//': '//trim(msg)
        return
      end if
      if (k == 1) dt = d
    end do
  end subroutine record_common_step

  !> The first and last sample of manoeuvre k of n samples whose manoeuvres
  !> start at the samples starts (clipped to 1 .. n).
  pure subroutine manoeuvre_bounds(starts, k, n, first, last)
    integer, intent(in) :: starts(:), k, n
    integer, intent(out) :: first, last
    first = max(1, starts(k))
    last = n
    if (k < size(starts)) last = min(n, starts(k + 1) - 1)
  end subroutine manoeuvre_bounds

  !> The median of x (quickselect on a copy).
  real(wp) function median(x)
    real(wp), intent(in) :: x(:)
    real(wp) :: a(size(x))
    a = x
    median = select_kth(a, (size(a) + 1)/2)
    if (mod(size(a), 2) == 0) median = 0.5_wp*(median + minval(a((size(a) + 1)/2 + 1:)))
  end function median

  !> The k-th smallest of a; a is left partitioned about it.
  real(wp) function select_kth(a, k)
    real(wp), intent(inout) :: a(:)
    integer, intent(in) :: k
    integer :: lo, hi, i, j
    real(wp) :: pivot
    lo = 1
    hi = size(a)
    do while (lo < hi)
      pivot = a((lo + hi)/2)
      i = lo
      j = hi
      do while (i <= j)
        do while (a(i) < pivot)
          i = i + 1
        end do
        do while (a(j) > pivot)
          j = j - 1
        end do
        if (i <= j) then
          a([i, j]) = a([j, i])
          i = i + 1
          j = j - 1
        end if
      end do
      if (k <= j) then
        hi = j
      else if (k >= i) then
        lo = i
      else
        exit
      end if
    end do
    select_kth = a(k)
  end function select_kth

end module mlid_sampling
