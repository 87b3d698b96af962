!> Units a flight record may declare, and how each converts to the core's
!> units (SI, angles in rad, temperatures in K): core = factor*value + offset.
!> One table; both front ends ask it.  Names are matched case-insensitively
!> after blanks are removed; '^2' and '2' are the same power.
module mlid_units
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: to_lower
  implicit none
  private
  public :: unit_to_core, unit_names, units_of, UNITLEN

  !> Room for a unit's name in records, reports and the flat interface.
  integer, parameter :: UNITLEN = 16

  real(wp), parameter :: DEG = acos(-1.0_wp)/180.0_wp, FT = 0.3048_wp, G0 = 9.80665_wp, &
                         KT = 1852.0_wp/3600.0_wp, LB = 0.45359237_wp

  type :: unit_t
    character(len=8) :: name, core
    real(wp) :: factor, offset
  end type unit_t

  type(unit_t), parameter :: UNITS(*) = [ &
    unit_t('', '', 1.0_wp, 0.0_wp), unit_t('-', '', 1.0_wp, 0.0_wp), &
    unit_t('1', '', 1.0_wp, 0.0_wp), unit_t('%', '%', 1.0_wp, 0.0_wp), &
    unit_t('s', 's', 1.0_wp, 0.0_wp), unit_t('ms', 's', 1.0e-3_wp, 0.0_wp), &
    unit_t('rad', 'rad', 1.0_wp, 0.0_wp), unit_t('rad/s', 'rad/s', 1.0_wp, 0.0_wp), &
    unit_t('rad/s2', 'rad/s2', 1.0_wp, 0.0_wp), &
    unit_t('deg', 'rad', DEG, 0.0_wp), unit_t('deg/s', 'rad/s', DEG, 0.0_wp), &
    unit_t('deg/s2', 'rad/s2', DEG, 0.0_wp), &
    unit_t('m', 'm', 1.0_wp, 0.0_wp), unit_t('km', 'm', 1.0e3_wp, 0.0_wp), &
    unit_t('ft', 'm', FT, 0.0_wp), unit_t('nmi', 'm', 1852.0_wp, 0.0_wp), &
    unit_t('m/s', 'm/s', 1.0_wp, 0.0_wp), unit_t('ft/s', 'm/s', FT, 0.0_wp), &
    unit_t('ft/min', 'm/s', FT/60.0_wp, 0.0_wp), unit_t('km/h', 'm/s', 1.0_wp/3.6_wp, 0.0_wp), &
    unit_t('kt', 'm/s', KT, 0.0_wp), unit_t('kts', 'm/s', KT, 0.0_wp), &
    unit_t('kn', 'm/s', KT, 0.0_wp), &
    unit_t('m/s2', 'm/s2', 1.0_wp, 0.0_wp), unit_t('ft/s2', 'm/s2', FT, 0.0_wp), &
    unit_t('g', 'm/s2', G0, 0.0_wp), &
    unit_t('N', 'N', 1.0_wp, 0.0_wp), unit_t('kN', 'N', 1.0e3_wp, 0.0_wp), &
    unit_t('lbf', 'N', LB*G0, 0.0_wp), &
    unit_t('kg', 'kg', 1.0_wp, 0.0_wp), unit_t('lb', 'kg', LB, 0.0_wp), &
    unit_t('Pa', 'Pa', 1.0_wp, 0.0_wp), unit_t('hPa', 'Pa', 100.0_wp, 0.0_wp), &
    unit_t('mbar', 'Pa', 100.0_wp, 0.0_wp), unit_t('kPa', 'Pa', 1.0e3_wp, 0.0_wp), &
    unit_t('K', 'K', 1.0_wp, 0.0_wp), unit_t('degC', 'K', 1.0_wp, 273.15_wp), &
    unit_t('kg/m3', 'kg/m3', 1.0_wp, 0.0_wp), &
    unit_t('Nm', 'Nm', 1.0_wp, 0.0_wp), unit_t('N.m', 'Nm', 1.0_wp, 0.0_wp)]

contains

  !> The factor and offset from unit to the core's unit, and that unit.
  subroutine unit_to_core(unit, factor, offset, core_unit, status, msg)
    character(len=*), intent(in) :: unit
    real(wp), intent(out) :: factor, offset
    character(len=*), intent(out) :: core_unit
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=len(unit)) :: key
    integer :: k

    key = normal(unit)
    do k = 1, size(UNITS)
      if (to_lower(UNITS(k)%name) /= to_lower(key)) cycle
      factor = UNITS(k)%factor
      offset = UNITS(k)%offset
      core_unit = UNITS(k)%core
      status = MLID_OK
      msg = ''
      return
    end do
    factor = 1.0_wp
    offset = 0.0_wp
    core_unit = ''
    status = MLID_ERR_INPUT
    msg = 'unknown unit '''//trim(unit)//''' (known: '//unit_names()//')'
  end subroutine unit_to_core

  !> The units known, for messages and documentation.
  function unit_names() result(text)
    character(len=:), allocatable :: text
    integer :: k
    text = ''
    do k = 5, size(UNITS)
      text = text//trim(UNITS(k)%name)//' '
    end do
    text = text//'- (none)'
  end function unit_names

  !> The units that convert to core unit core, for messages.
  function units_of(core) result(text)
    character(len=*), intent(in) :: core
    character(len=:), allocatable :: text
    integer :: k
    text = ''
    do k = 1, size(UNITS)
      if (UNITS(k)%core == core .and. len_trim(UNITS(k)%name) > 0) &
        text = text//' '//trim(UNITS(k)%name)
    end do
    if (len(text) > 0) text = text(2:)
  end function units_of

  !> Blanks removed; '^2', '²' and '^3', '³' written as 2 and 3.
  pure function normal(unit) result(key)
    character(len=*), intent(in) :: unit
    character(len=len(unit)) :: key
    character(len=*), parameter :: SQ = char(194)//char(178), CU = char(194)//char(179)
    integer :: i, n
    key = ''
    n = 0
    i = 1
    do while (i <= len_trim(unit))
      if (unit(i:i) == ' ' .or. unit(i:i) == '^') then
        i = i + 1
        cycle
      end if
      n = n + 1
      if (i < len(unit)) then
        if (unit(i:i + 1) == SQ .or. unit(i:i + 1) == CU) then
          key(n:n) = merge('2', '3', unit(i:i + 1) == SQ)
          i = i + 2
          cycle
        end if
      end if
      key(n:n) = unit(i:i)
      i = i + 1
    end do
  end function normal

end module mlid_units
