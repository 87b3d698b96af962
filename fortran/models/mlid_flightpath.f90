!> Flight-path reconstruction (data compatibility), written out as an
!> equations model (mlid_equations): the kinematic equations driven by the
!> measured accelerations and rates (textbook eqs. 10.8, 10.11-10.13).
!>
!> States u, v, w (inertial velocity, body axes), phi, theta, psi, h; inputs
!> ax, ay, az (accelerometers), p, q, r (rate gyros), pdot, qdot, rdot;
!> outputs any of V, alpha, beta (air data at the nose boom for the vanes),
!> phi, theta, psi, h.  The constants place the accelerometer (xA, yA, zA)
!> and the air-data boom (xN, yN, zN) from the centre of gravity, body axes.
!>
!> The sensor corrections are the model's parameters, each present only
!> when the case names it (absent ones cost nothing and are neutral):
!>   b_ax b_ay b_az f_ax f_ay f_az   accelerometer a = (a_m - b)/f
!>   b_p b_q b_r f_p f_q f_r          rate gyro     p = (p_m - b)/f
!>   f_V b_V f_al b_al f_be b_be      air data      V_m = f V + b, ...
!>   w_n w_e w_d                      a constant wind (earth axes, m/s)
!> Biases of the attitude and height outputs and every sensor's time delay
!> are the blocks bias(i) and delay(i) that every model has.
module mlid_flightpath
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: joined
  implicit none
  private
  public :: flightpath_text, flightpath_corrected, FLIGHTPATH_CONSTANTS, &
            FLIGHTPATH_CORRECTIONS, FLIGHTPATH_OUTPUTS, FLIGHTPATH_INPUTS

  character(len=*), parameter :: FLIGHTPATH_CONSTANTS = 'xA, yA, zA, xN, yN, zN, g'
  character(len=2), parameter :: CONST_NAME(7) = [character(len=2) :: 'xA', 'yA', 'zA', 'xN', &
                                                  'yN', 'zN', 'g']
  character(len=4), parameter :: FLIGHTPATH_CORRECTIONS(21) = [character(len=4) :: &
    'b_ax', 'b_ay', 'b_az', 'f_ax', 'f_ay', 'f_az', 'b_p', 'b_q', 'b_r', 'f_p', 'f_q', 'f_r', &
    'f_V', 'b_V', 'f_al', 'b_al', 'f_be', 'b_be', 'w_n', 'w_e', 'w_d']
  character(len=5), parameter :: FLIGHTPATH_OUTPUTS(7) = [character(len=5) :: 'V', 'alpha', &
                                                          'beta', 'phi', 'theta', 'psi', 'h']
  character(len=4), parameter :: FLIGHTPATH_INPUTS(9) = [character(len=4) :: 'ax', 'ay', 'az', &
                                                         'p', 'q', 'r', 'pdot', 'qdot', 'rdot']
  character(len=5), parameter :: STATES(7) = [character(len=5) :: 'u', 'v', 'w', 'phi', 'theta', &
                                              'psi', 'h']
  character(len=*), parameter :: XDOT(7) = [character(len=64) :: &
    'axg - g*sin(theta) + rc*v - qc*w', &
    'ayg + g*sin(phi)*cos(theta) + pc*w - rc*u', &
    'azg + g*cos(phi)*cos(theta) + qc*u - pc*v', &
    'pc + (qc*sin(phi) + rc*cos(phi))*tan(theta)', &
    'qc*cos(phi) - rc*sin(phi)', &
    '(qc*sin(phi) + rc*cos(phi))/cos(theta)', &
    'u*sin(theta) - v*sin(phi)*cos(theta) - w*cos(phi)*cos(theta)']
  character(len=1), parameter :: NL = achar(10)

contains

  !> The whole model text for consts = [xA, yA, zA, xN, yN, zN, g], the
  !> corrections present (pnames, in the order of p) and the outputs
  !> (ynames, in output order).
  subroutine flightpath_text(consts, pnames, ynames, text, status, msg)
    real(wp), intent(in) :: consts(:)
    character(len=*), intent(in) :: pnames(:), ynames(:)
    character(len=:), allocatable, intent(out) :: text
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=24) :: num
    integer :: k

    text = ''
    call check(consts, pnames, ynames, status, msg)
    if (status /= MLID_OK) return
    do k = 1, size(FLIGHTPATH_INPUTS)
      text = text//'u '//trim(FLIGHTPATH_INPUTS(k))//NL
    end do
    do k = 1, size(pnames)
      text = text//'p '//trim(pnames(k))//NL
    end do
    do k = 1, size(consts)
      write (num, '(es24.16e3)') consts(k)
      text = text//'l '//trim(CONST_NAME(k))//' = '//trim(adjustl(num))//NL
    end do
    do k = 1, 6                                ! the corrected accelerations and rates
      text = text//'l '//trim(FLIGHTPATH_INPUTS(k))//'c = '// &
             corrected(FLIGHTPATH_INPUTS(k), 'b_'//FLIGHTPATH_INPUTS(k), 'f_'//FLIGHTPATH_INPUTS(k))//NL
    end do
    ! the accelerometer's reading moved to the centre of gravity (pdot, qdot, rdot as measured)
    text = text//'l axg = axc + xA*(qc^2 + rc^2) - yA*(pc*qc - rdot) - zA*(pc*rc + qdot)'//NL// &
           'l ayg = ayc - xA*(pc*qc + rdot) + yA*(pc^2 + rc^2) - zA*(qc*rc - pdot)'//NL// &
           'l azg = azc - xA*(pc*rc - qdot) - yA*(qc*rc + pdot) + zA*(pc^2 + qc^2)'//NL
    text = text//air_velocity(pnames)
    do k = 1, size(STATES)
      text = text//'x '//trim(STATES(k))//' = '//trim(XDOT(k))//NL
    end do
    do k = 1, size(ynames)
      text = text//'y '//trim(ynames(k))//' = '//output(ynames(k))//NL
    end do

  contains

    !> (m - b)/f, with only the corrections present.
    function corrected(m, b, f) result(e)
      character(len=*), intent(in) :: m, b, f
      character(len=:), allocatable :: e
      e = trim(m)
      if (any(pnames == b)) e = '('//e//' - '//trim(b)//')'
      if (any(pnames == f)) e = e//'/'//trim(f)
    end function corrected

    !> f*e + b, with only the corrections present.
    function measured(e, f, b) result(s)
      character(len=*), intent(in) :: e, f, b
      character(len=:), allocatable :: s
      s = e
      if (any(pnames == f)) s = trim(f)//'*'//s
      if (any(pnames == b)) s = s//' + '//trim(b)
    end function measured

    function output(name) result(e)
      character(len=*), intent(in) :: name
      character(len=:), allocatable :: e
      select case (trim(name))
      case ('V')
        e = measured('sqrt(ua^2 + va^2 + wa^2)', 'f_V', 'b_V')
      case ('alpha')
        e = measured('atan2(wN, uN)', 'f_al', 'b_al')
      case ('beta')
        e = measured('atan2(vN, uN)', 'f_be', 'b_be')
      case default
        e = trim(name)
      end select
    end function output

  end subroutine flightpath_text

  !> One manoeuvre's record (t, u(9, n), y(ny, n)) with a flight-path fit's
  !> corrections undone, for the next step (the aerodynamic model): each
  !> input taken back by its delay (the model sees the measurement at t -
  !> udelay), the accelerometers and gyros then a = (a_m - b)/f; each output
  !> taken back by its delay (the measurement at t + delay), less its bias,
  !> and the air data (V, alpha, beta) = (y_m - b)/f.  A shift is linear
  !> between samples and held beyond the manoeuvre.  unames, pnames, ynames:
  !> the model's inputs, corrections and outputs; p: the corrections'
  !> values; bias, delay, udelay: the manoeuvre's.
  subroutine flightpath_corrected(unames, pnames, p, ynames, bias, delay, udelay, t, u, y, &
                                  status, msg)
    character(len=*), intent(in) :: unames(:), pnames(:), ynames(:)
    real(wp), intent(in) :: p(:), bias(:), delay(:), udelay(:), t(:)
    real(wp), intent(inout) :: u(:, :), y(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, i

    status = MLID_ERR_INPUT
    if (size(unames) /= size(FLIGHTPATH_INPUTS)) then
      msg = 'corrected record: not a flight-path model (its inputs are not '// &
            joined(FLIGHTPATH_INPUTS)//')'
      return
    else if (any(unames /= FLIGHTPATH_INPUTS) .or. any(.not. [(any(FLIGHTPATH_CORRECTIONS == &
             pnames(k)), k=1, size(pnames))]) .or. any(.not. [(any(FLIGHTPATH_OUTPUTS == &
             ynames(i)), i=1, size(ynames))])) then
      msg = 'corrected record: not a flight-path model (its inputs are not '// &
            joined(FLIGHTPATH_INPUTS)//', or it has parameters or outputs the kind has not)'
      return
    end if
    if (size(p) /= size(pnames) .or. size(y, 1) /= size(ynames) .or. size(bias) /= size(ynames) &
        .or. size(delay) /= size(ynames) .or. size(udelay) /= size(unames) .or. &
        size(u, 1) /= size(unames) .or. size(u, 2) /= size(t) .or. size(y, 2) /= size(t)) then
      msg = 'corrected record: p, bias, delay, udelay and the record disagree in size with the model'
      return
    end if
    do k = 1, size(unames)
      u(k, :) = shifted(u(k, :), -udelay(k))
      if (k <= 6) u(k, :) = (u(k, :) - value('b_'//FLIGHTPATH_INPUTS(k), 0.0_wp))/ &
                            value('f_'//FLIGHTPATH_INPUTS(k), 1.0_wp)
    end do
    do i = 1, size(ynames)
      y(i, :) = shifted(y(i, :), delay(i)) - bias(i)
      select case (trim(ynames(i)))
      case ('V')
        y(i, :) = (y(i, :) - value('b_V', 0.0_wp))/value('f_V', 1.0_wp)
      case ('alpha')
        y(i, :) = (y(i, :) - value('b_al', 0.0_wp))/value('f_al', 1.0_wp)
      case ('beta')
        y(i, :) = (y(i, :) - value('b_be', 0.0_wp))/value('f_be', 1.0_wp)
      end select
    end do
    status = MLID_OK
    msg = ''

  contains

    !> The value of correction name, or its neutral value when the model has none.
    real(wp) function value(name, neutral)
      character(len=*), intent(in) :: name
      real(wp), intent(in) :: neutral
      integer :: j
      j = findloc(pnames, trim(name), 1)
      value = neutral
      if (j > 0) value = p(j)
    end function value

    !> s at t + tau, linear between samples, held beyond the ends; a sample
    !> hit exactly is that sample (tau = 0 changes nothing).
    function shifted(s, tau) result(r)
      real(wp), intent(in) :: s(:), tau
      real(wp) :: r(size(s)), tj
      integer :: j, m
      r = s
      if (tau == 0.0_wp) return
      m = 1
      do j = 1, size(t)
        tj = t(j) + tau
        if (tj <= t(1)) then
          r(j) = s(1)
        else if (tj >= t(size(t))) then
          r(j) = s(size(t))
        else
          do while (t(m + 1) <= tj)            ! t(m) <= tj < t(m+1): m only grows with j
            m = m + 1
          end do
          do while (t(m) > tj)
            m = m - 1
          end do
          r(j) = s(m)
          if (tj > t(m)) r(j) = s(m) + (s(m + 1) - s(m))*(tj - t(m))/(t(m + 1) - t(m))
        end if
      end do
    end function shifted

  end subroutine flightpath_corrected

  !> The velocity relative to the air at the centre of gravity (ua, va, wa)
  !> and at the boom (uN, vN, wN), with the wind turned into body axes when
  !> the case has one.
  function air_velocity(pnames) result(text)
    character(len=*), intent(in) :: pnames(:)
    character(len=:), allocatable :: text
    if (any(pnames == 'w_n') .or. any(pnames == 'w_e') .or. any(pnames == 'w_d')) then
      text = 'l wn = '//have('w_n')//NL//'l we = '//have('w_e')//NL//'l wd = '//have('w_d')//NL// &
        'l ua = u - (cos(theta)*cos(psi)*wn + cos(theta)*sin(psi)*we - sin(theta)*wd)'//NL// &
        'l va = v - ((sin(phi)*sin(theta)*cos(psi) - cos(phi)*sin(psi))*wn + '// &
        '(sin(phi)*sin(theta)*sin(psi) + cos(phi)*cos(psi))*we + sin(phi)*cos(theta)*wd)'//NL// &
        'l wa = w - ((cos(phi)*sin(theta)*cos(psi) + sin(phi)*sin(psi))*wn + '// &
        '(cos(phi)*sin(theta)*sin(psi) - sin(phi)*cos(psi))*we + cos(phi)*cos(theta)*wd)'//NL
    else
      text = 'l ua = u'//NL//'l va = v'//NL//'l wa = w'//NL
    end if
    text = text//'l uN = ua - rc*yN + qc*zN'//NL//'l vN = va - pc*zN + rc*xN'//NL// &
           'l wN = wa - qc*xN + pc*yN'//NL

  contains

    function have(name) result(e)
      character(len=*), intent(in) :: name
      character(len=:), allocatable :: e
      e = merge(name, '0  ', any(pnames == name))
      e = trim(e)
    end function have

  end function air_velocity

  !> Sound constants, known corrections and outputs, each named once.
  subroutine check(consts, pnames, ynames, status, msg)
    real(wp), intent(in) :: consts(:)
    character(len=*), intent(in) :: pnames(:), ynames(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k

    status = MLID_ERR_INPUT
    msg = ''
    if (size(consts) /= 7) then
      msg = 'flight-path model: constants needs 7 values: '//FLIGHTPATH_CONSTANTS
    else if (any(consts /= consts) .or. .not. consts(7) > 0.0_wp) then
      msg = 'flight-path model: the constants must be numbers and g > 0'
    else if (size(ynames) == 0) then
      msg = 'flight-path model: no outputs; choose from '//joined(FLIGHTPATH_OUTPUTS)
    end if
    if (len_trim(msg) > 0) return
    do k = 1, size(pnames)
      if (.not. any(FLIGHTPATH_CORRECTIONS == pnames(k))) then
        msg = 'flight-path model: '''//trim(pnames(k))//''' is not a correction; the '// &
              'corrections are '//joined(FLIGHTPATH_CORRECTIONS)
      else if (count(pnames == pnames(k)) > 1) then
        msg = 'flight-path model: correction '''//trim(pnames(k))//''' is given twice'
      end if
      if (len_trim(msg) > 0) return
    end do
    do k = 1, size(ynames)
      if (.not. any(FLIGHTPATH_OUTPUTS == ynames(k))) then
        msg = 'flight-path model: output '''//trim(ynames(k))//''' is not one of '// &
              joined(FLIGHTPATH_OUTPUTS)
      else if (count(ynames == ynames(k)) > 1) then
        msg = 'flight-path model: output '''//trim(ynames(k))//''' is given twice'
      end if
      if (len_trim(msg) > 0) return
    end do
    status = MLID_OK
  end subroutine check

end module mlid_flightpath
