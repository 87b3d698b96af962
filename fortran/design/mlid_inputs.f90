!> Standard flight-test input shapes on a uniform time base.
!>
!> Pulse edges are placed on whole samples (widths rounded to samples) so
!> that every caller gets the same signal whatever the rounding of t.
module mlid_inputs
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: to_lower, es_text
  implicit none
  private
  public :: input_signal, INPUT_SHAPES

  character(len=*), parameter :: INPUT_SHAPES = 'none, step, pulse, doublet, 211, 3211'

contains

  !> u(k) at t(k) = (k-1)*dt for a named shape of amplitude a starting at
  !> t_start with unit pulse width pw:
  !>   step: a from t_start on; pulse: a for pw; doublet: +a for pw, -a for pw;
  !>   211: +a for 2pw, -a for pw, +a for pw;
  !>   3211: +a for 3pw, -a for 2pw, +a for pw, -a for pw.
  subroutine input_signal(shape, a, t_start, pw, dt, u, status, msg)
    character(len=*), intent(in) :: shape
    real(wp), intent(in) :: a, t_start, pw, dt
    real(wp), intent(out) :: u(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k0, w, k
    integer, allocatable :: widths(:)
    real(wp), allocatable :: signs(:)

    status = MLID_OK
    msg = ''
    u = 0.0_wp
    if (.not. dt > 0.0_wp) then
      status = MLID_ERR_INPUT
      msg = 'input signal: dt must be > 0'
      return
    end if
    if (.not. (ieee_is_finite(a) .and. ieee_is_finite(t_start) .and. ieee_is_finite(pw) .and. &
               ieee_is_finite(dt))) then
      status = MLID_ERR_INPUT
      msg = 'input signal: amplitude, t_start, pulse_width and dt must be finite'
      return
    end if
    if (to_lower(shape) == 'none') return
    if (t_start < 0.0_wp .or. t_start > real(size(u) - 1, wp)*dt) then
      status = MLID_ERR_INPUT
      msg = 'input signal: t_start ='//es_text(t_start, 10, 3)//' s lies outside the record '// &
            '(0 to'//es_text(real(size(u) - 1, wp)*dt, 10, 3)//' s)'
      return
    end if
    ! both in samples; a pulse wider than the record acts as the record
    k0 = nint(t_start/dt) + 1
    w = nint(min(max(pw/dt, 0.0_wp), real(size(u), wp)))
    select case (trim(to_lower(shape)))
    case ('step')
      if (k0 <= size(u)) u(max(1, k0):) = a
      return
    case ('pulse')
      widths = [1]
      signs = [1.0_wp]
    case ('doublet')
      widths = [1, 1]
      signs = [1.0_wp, -1.0_wp]
    case ('211')
      widths = [2, 1, 1]
      signs = [1.0_wp, -1.0_wp, 1.0_wp]
    case ('3211')
      widths = [3, 2, 1, 1]
      signs = [1.0_wp, -1.0_wp, 1.0_wp, -1.0_wp]
    case default
      status = MLID_ERR_INPUT
      msg = 'unknown input shape '''//trim(shape)//''': use '//INPUT_SHAPES
      return
    end select
    if (w < 1) then
      status = MLID_ERR_INPUT
      msg = 'input signal: pulse_width must be at least one sample'
      return
    end if
    do k = 1, size(widths)
      if (k0 > size(u)) exit
      u(k0:min(size(u), k0 + widths(k)*w - 1)) = signs(k)*a
      k0 = k0 + widths(k)*w
    end do
  end subroutine input_signal

end module mlid_inputs
