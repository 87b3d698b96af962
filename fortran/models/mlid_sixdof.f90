!> The six-degree-of-freedom rigid aircraft, written out as an equations
!> model (mlid_equations): body axes, states any of u, v, w, p, q, r, phi,
!> theta, psi, h; the aerodynamic coefficients are the user's definitions.
!>
!> The user states the coefficients as definitions over the air data this
!> module provides (V, alpha, beta, phat = p b/2V, qhat = q cbar/2V,
!> rhat = r b/2V), the inputs and the parameters: either C_X and C_Z (body
!> axes) or C_D and C_L (stability axes), and C_Y, C_l, C_m, C_n as the
!> states need them; and rho, optionally thrust T with its inclination sigT
!> (rad, nose up) and pitching-moment arm lT (m, M_T = lT T), each a
!> definition or an input.  This module adds the rest:
!>
!>   before the user's definitions: the constants m, Ix, Iy, Iz, Ixz, S,
!>     cbar, b, g and the air data;
!>   after them: CX, CZ from CD, CL; qbar; the specific forces at the centre
!>     of gravity ax, ay, az (what accelerometers there read); the moments
!>     Lmom, Mmom, Nmom; the angular accelerations pdot, qdot, rdot;
!>   the state equations of the states asked for.
!>
!> Any of u, v, w, p, q, r, phi, theta that is not a state must be an input:
!> the decoupled forms (longitudinal only, lateral only) take the other
!> axis's measured quantities that way.  Outputs are the user's, any
!> expression of these names (states, alpha, beta, V, ax, ..., pdot, ...).
module mlid_sixdof
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  implicit none
  private
  public :: sixdof_parts, SIXDOF_CONSTANTS

  !> The constants, in the order a deck's or Python's constants give them.
  character(len=*), parameter :: SIXDOF_CONSTANTS = 'm, Ix, Iy, Iz, Ixz, S, cbar, b, g'
  character(len=4), parameter :: CONST_NAME(9) = [character(len=4) :: 'm', 'Ix', 'Iy', 'Iz', &
                                                  'Ixz', 'S', 'cbar', 'b', 'g']
  character(len=5), parameter :: KINEMATIC(8) = [character(len=5) :: 'u', 'v', 'w', 'p', 'q', &
                                                 'r', 'phi', 'theta']
  character(len=5), parameter :: STATES(10) = [character(len=5) :: 'u', 'v', 'w', 'p', 'q', &
                                               'r', 'phi', 'theta', 'psi', 'h']
  !> Each state's equation, and the definition it needs ('' none).
  character(len=*), parameter :: XDOT(10) = [character(len=72) :: &
    'r*v - q*w - g*sin(theta) + ax', &
    'p*w - r*u + g*cos(theta)*sin(phi) + ay', &
    'q*u - p*v + g*cos(theta)*cos(phi) + az', &
    'pdot', 'qdot', 'rdot', &
    'p + (q*sin(phi) + r*cos(phi))*tan(theta)', &
    'q*cos(phi) - r*sin(phi)', &
    '(q*sin(phi) + r*cos(phi))/cos(theta)', &
    'u*sin(theta) - v*sin(phi)*cos(theta) - w*cos(phi)*cos(theta)']
  character(len=4), parameter :: NEEDS(10) = [character(len=4) :: 'ax', 'ay', 'az', 'pdot', &
                                              'qdot', 'rdot', '', '', '', '']

contains

  !> The lines (mlid_equations' text, newline-ended) that go before the
  !> user's definitions (pre), after them (post), and the state equations
  !> (xs), for consts = [m, Ix, Iy, Iz, Ixz, S, cbar, b, g], the states, the
  !> inputs and the names the user's definitions define.
  subroutine sixdof_parts(consts, xnames, unames, defined, pre, post, xs, status, msg)
    real(wp), intent(in) :: consts(:)
    character(len=*), intent(in) :: xnames(:), unames(:), defined(:)
    character(len=:), allocatable, intent(out) :: pre, post, xs
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=24) :: num
    character(len=:), allocatable :: have
    integer :: k, i

    pre = ''
    post = ''
    xs = ''
    call check(consts, xnames, unames, defined, status, msg)
    if (status /= MLID_OK) return
    do k = 1, 9
      write (num, '(es24.16e3)') consts(k)
      pre = pre//'l '//trim(CONST_NAME(k))//' = '//trim(adjustl(num))//achar(10)
    end do
    pre = pre//'l V = sqrt(u^2 + v^2 + w^2)'//achar(10)//'l alpha = atan2(w, u)'//achar(10)// &
          'l beta = asin(v/V)'//achar(10)//'l phat = p*b/(2*V)'//achar(10)// &
          'l qhat = q*cbar/(2*V)'//achar(10)//'l rhat = r*b/(2*V)'//achar(10)
    have = ' '//join(defined)//' '//join(unames)//' '   ! a definition or an input
    if (has(have, 'CD')) post = post//'l CX = -CD*cos(alpha) + CL*sin(alpha)'//achar(10)// &
                                'l CZ = -CD*sin(alpha) - CL*cos(alpha)'//achar(10)
    post = post//'l qbar = 0.5*rho*V^2'//achar(10)
    if (has(have, 'CD') .or. has(have, 'CX')) post = post// &
      'l ax = (qbar*S*CX + '//thrust(have, 'cos')//')/m'//achar(10)// &
      'l az = (qbar*S*CZ - '//thrust(have, 'sin')//')/m'//achar(10)
    if (has(have, 'CY')) post = post//'l ay = qbar*S*CY/m'//achar(10)
    if (has(have, 'Cl') .and. has(have, 'Cn')) post = post// &
      'l Lmom = qbar*S*b*Cl'//achar(10)//'l Nmom = qbar*S*b*Cn'//achar(10)// &
      'l pdot = (Iz*Lmom + Ixz*Nmom + Ixz*(Ix - Iy + Iz)*p*q - (Iz*(Iz - Iy) + Ixz^2)*q*r)'// &
      '/(Ix*Iz - Ixz^2)'//achar(10)// &
      'l rdot = (Ixz*Lmom + Ix*Nmom + (Ix*(Ix - Iy) + Ixz^2)*p*q - Ixz*(Ix - Iy + Iz)*q*r)'// &
      '/(Ix*Iz - Ixz^2)'//achar(10)
    if (has(have, 'Cm')) post = post//'l Mmom = qbar*S*cbar*Cm + '//moment_arm(have)//'*'// &
      thrust(have, '')//achar(10)//'l qdot = (Mmom + (Iz - Ix)*p*r - Ixz*(p^2 - r^2))/Iy'// &
      achar(10)
    do k = 1, size(xnames)
      i = findloc(STATES, trim(xnames(k)), 1)
      xs = xs//'x '//trim(xnames(k))//' = '//trim(XDOT(i))//achar(10)
    end do
  end subroutine sixdof_parts

  !> What the model needs: sound constants, known states, every kinematic
  !> quantity a state or an input, the coefficients the states need.
  subroutine check(consts, xnames, unames, defined, status, msg)
    real(wp), intent(in) :: consts(:)
    character(len=*), intent(in) :: xnames(:), unames(:), defined(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=:), allocatable :: have
    integer :: k, i

    status = MLID_ERR_INPUT
    msg = ''
    if (size(consts) /= 9) then
      msg = 'six-degree-of-freedom model: constants needs 9 values: '//SIXDOF_CONSTANTS
    else if (any(consts([1, 2, 3, 4, 6, 7, 8, 9]) <= 0.0_wp) .or. any(consts /= consts)) then
      msg = 'six-degree-of-freedom model: m, Ix, Iy, Iz, S, cbar, b and g must be > 0'
    else if (consts(2)*consts(4) - consts(5)**2 <= 0.0_wp) then
      msg = 'six-degree-of-freedom model: the inertia matrix is not positive definite '// &
            '(Ix Iz - Ixz^2 <= 0)'
    end if
    if (len_trim(msg) > 0) return
    have = ' '//join(defined)//' '//join(unames)//' '   ! a definition or an input
    do k = 1, size(xnames)
      i = findloc(STATES, trim(xnames(k)), 1)
      if (i == 0) then
        msg = 'six-degree-of-freedom model: state '''//trim(xnames(k))//''' is not one of '// &
              'u v w p q r phi theta psi h'
        return
      end if
      if (len_trim(NEEDS(i)) > 0 .and. .not. provides(have, NEEDS(i))) then
        msg = 'six-degree-of-freedom model: state '//trim(xnames(k))//' needs '// &
              trim(coefficient_of(NEEDS(i)))//' among the definitions'
        return
      end if
    end do
    do k = 1, size(KINEMATIC)
      if (any(xnames == KINEMATIC(k)) .or. any(unames == KINEMATIC(k))) cycle
      msg = 'six-degree-of-freedom model: '''//trim(KINEMATIC(k))//''' is neither a state '// &
            'nor an input (a decoupled form takes the other axis''s measured quantities as inputs)'
      return
    end do
    if (.not. has(have, 'rho')) then
      msg = 'six-degree-of-freedom model: define rho (air density, a number or an input)'
      return
    end if
    if (has(have, 'CD') .neqv. has(have, 'CL')) then
      msg = 'six-degree-of-freedom model: define both CD and CL (stability axes), or CX and CZ'
      return
    end if
    if (has(have, 'CD') .and. (has(have, 'CX') .or. has(have, 'CZ'))) then
      msg = 'six-degree-of-freedom model: define CD and CL, or CX and CZ, not both'
      return
    end if
    status = MLID_OK
  end subroutine check

  !> Whether the user's definitions provide what a state equation reads.
  logical function provides(have, what)
    character(len=*), intent(in) :: have, what
    select case (trim(what))
    case ('ax', 'az')
      provides = (has(have, 'CX') .and. has(have, 'CZ')) .or. has(have, 'CD')
    case ('ay')
      provides = has(have, 'CY')
    case ('qdot')
      provides = has(have, 'Cm')
    case default                         ! pdot, rdot
      provides = has(have, 'Cl') .and. has(have, 'Cn')
    end select
  end function provides

  function coefficient_of(what) result(c)
    character(len=*), intent(in) :: what
    character(len=:), allocatable :: c
    select case (trim(what))
    case ('ax', 'az')
      c = 'CX and CZ (or CD and CL)'
    case ('ay')
      c = 'CY'
    case ('qdot')
      c = 'Cm'
    case default
      c = 'Cl and Cn'
    end select
  end function coefficient_of

  !> The thrust's part in a force ('T*cos(sigT)', '0' without thrust).
  function thrust(have, trig) result(t)
    character(len=*), intent(in) :: have, trig
    character(len=:), allocatable :: t
    t = '0'
    if (.not. has(have, 'T')) return
    t = 'T'
    if (len(trig) > 0 .and. has(have, 'sigT')) t = 'T*'//trig//'(sigT)'
    if (trig == 'sin' .and. .not. has(have, 'sigT')) t = '0'
  end function thrust

  function moment_arm(have) result(a)
    character(len=*), intent(in) :: have
    character(len=:), allocatable :: a
    a = '0'
    if (has(have, 'lT')) a = 'lT'
  end function moment_arm

  logical function has(have, name)
    character(len=*), intent(in) :: have, name
    has = index(have, ' '//trim(name)//' ') > 0
  end function has

  function join(names) result(s)
    character(len=*), intent(in) :: names(:)
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    do k = 1, size(names)
      s = s//' '//trim(names(k))
    end do
  end function join

end module mlid_sixdof
