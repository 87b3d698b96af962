!> Time delays of the outputs: a sensor that reports late by tau.
!>
!> An output delayed by tau (s) is the model output at t - tau, interpolated
!> linearly between the two samples of its manoeuvre that bracket t - tau
!> (held at the manoeuvre's first sample before it starts).  A lead (tau < 0)
!> is extrapolated from the sample and the one before it, so the rule is
!> linear in tau through zero: the delay's derivative is continuous at its
!> usual start value 0, and for |tau| < dt the rule is the time shift of the
!> textbook software's flight-path reconstruction (its test case 33).  A
!> lead of a sample or more is refused (delay_check): extrapolated further it
!> is wrong, and interpolated it jumps at one sample.  The
!> delay is a parameter like any other (theta's block 'delay', one per
!> output): its sensitivity is the chain rule through the interpolation,
!> the negative slope between the two samples used.
module mlid_delay
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  implicit none
  private
  public :: delay_outputs, delay_check

contains

  !> Delay output rows y(i, j0:j1) of one manoeuvre by tau(i); with dy
  !> (ny, nf, nt), their sensitivities too, and the delays' own columns:
  !> free delay i (or one tied to it) adds weight w(k) times its partial to
  !> column col(k) (idx(k) = i).
  pure subroutine delay_outputs(tau, t, j0, j1, y, dy, idx, col, w)
    real(wp), intent(in) :: tau(:), t(:)
    integer, intent(in) :: j0, j1
    real(wp), intent(inout) :: y(:, :)
    real(wp), intent(inout), optional :: dy(:, :, :)
    integer, intent(in), optional :: idx(:), col(:)
    real(wp), intent(in), optional :: w(:)
    real(wp), allocatable :: y0(:), dy0(:, :)
    real(wp) :: s, a, slope
    integer :: i, j, k, m

    do i = 1, size(tau)
      if (tau(i) == 0.0_wp .and. .not. moving(i)) cycle
      y0 = y(i, j0:j1)                   ! the undelayed row, indexed from 1
      if (present(dy)) dy0 = dy(i, :, j0:j1)
      m = 2
      do j = j0, j1
        s = t(j) - tau(i)
        if (j == j0 .or. s <= t(j0)) then      ! before the manoeuvre: held
          y(i, j) = y0(1)
          if (present(dy)) dy(i, :, j) = dy0(:, 1)
          cycle
        end if
        if (tau(i) < 0.0_wp) then              ! a lead: from samples j-1 and j
          m = j - j0 + 1
        else                                   ! t(j0+m-2) < s <= t(j0+m-1)
          do while (t(j0 + m - 1) < s)
            m = m + 1
          end do
          do while (t(j0 + m - 2) >= s)
            m = m - 1
          end do
        end if
        a = (t(j0 + m - 1) - s)/(t(j0 + m - 1) - t(j0 + m - 2))
        slope = (y0(m - 1) - y0(m))/(t(j0 + m - 1) - t(j0 + m - 2))
        y(i, j) = (1.0_wp - a)*y0(m) + a*y0(m - 1)
        if (.not. present(dy)) cycle
        dy(i, :, j) = (1.0_wp - a)*dy0(:, m) + a*dy0(:, m - 1)
        do k = 1, size(idx)
          if (idx(k) == i) dy(i, col(k), j) = dy(i, col(k), j) + w(k)*slope
        end do
      end do
    end do

  contains

    pure logical function moving(i)
      integer, intent(in) :: i
      moving = .false.
      if (present(idx)) moving = any(idx == i)
    end function moving

  end subroutine delay_outputs

  !> A delay as long as its manoeuvre leaves nothing to fit, and a lead of a
  !> sample or more is beyond the rule (extrapolated from the sample before):
  !> status MLID_ERR_INPUT and msg naming the channel and the manoeuvre.
  pure subroutine delay_check(tau, t, j0, j1, iseg, what, status, msg)
    real(wp), intent(in) :: tau(:), t(:)
    integer, intent(in) :: j0, j1, iseg
    character(len=*), intent(in) :: what        !< the block: 'delay' or 'udelay'
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: step
    integer :: i
    status = MLID_OK
    msg = ''
    step = huge(1.0_wp)
    if (j1 > j0) step = minval(t(j0 + 1:j1) - t(j0:j1 - 1))
    do i = 1, size(tau)
      if (tau(i) /= 0.0_wp .and. abs(tau(i)) >= t(j1) - t(j0)) then
        write (msg, '(a,i0,3a,i0,3a)') what//'(', i, ') = ', num(tau(i)), &
          ' s is not shorter than manoeuvre ', iseg, ' (', num(t(j1) - t(j0)), ' s)'
      else if (-tau(i) >= step) then
        write (msg, '(a,i0,3a,i0,3a)') what//'(', i, ') = ', num(tau(i)), &
          ' s leads by a sample or more (manoeuvre ', iseg, ' steps by ', num(step), &
          ' s): a lead is extrapolated within a sample only; shift the channel in the record'
      end if
      if (len_trim(msg) == 0) cycle
      status = MLID_ERR_INPUT
      return
    end do
  end subroutine delay_check

  pure function num(x) result(text)
    real(wp), intent(in) :: x
    character(len=:), allocatable :: text
    character(len=16) :: buf
    write (buf, '(g0.4)') x
    if (abs(x) < 0.1_wp .and. x /= 0.0_wp) write (buf, '(es10.3)') x
    if (abs(x) < 1.0e-99_wp .and. x /= 0.0_wp) write (buf, '(es11.3e3)') x   ! not '1.000-150'
    text = trim(adjustl(buf))
  end function num

end module mlid_delay
