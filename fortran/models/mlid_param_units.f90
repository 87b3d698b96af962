!> Units of a model's parameters, from the core units of its record's
!> channels (mlid_units): F(i,j) of a linear model is unit(x_i)/(s unit(x_j)),
!> a longitudinal coefficient of alpha is 1/rad, an output bias has its
!> output's unit, a measurement-noise variance its square.  '-' is
!> dimensionless, '' unknown (a channel without a unit, a state no output
!> shows, the X-22's and user models' own parameters, process noise).
module mlid_param_units
  use mlid_kinds, only: wp
  use mlid_units, only: UNITLEN
  use mlid_layout, only: layout_table_t
  use mlid_model_factory, only: MODEL_LINEAR, MODEL_AERO_LONG
  implicit none
  private
  public :: param_units, unit_ratio

  !> Symbols of the core's units; a unit is a power of each.
  character(len=3), parameter :: BASE(*) = [character(len=3) :: 'rad', 'm', 'kg', 'N', 'Nm', &
                                            'Pa', 'K', '%', 's']
  integer, parameter :: NB = size(BASE)

  type :: dim_t
    logical :: known = .false.
    integer :: e(NB) = 0
  end type dim_t

  !> The longitudinal model's states (V, alpha, theta, q) and its
  !> regressors' units (1, V/V0, alpha, alpha^2, qhat, delta_e); qhat = q cbar/(2 V0)
  !> is in rad, as C_mq is quoted per rad.
  character(len=5), parameter :: AERO_STATE(4) = [character(len=5) :: 'm/s', 'rad', 'rad', 'rad/s']
  character(len=5), parameter :: AERO_REG(6) = [character(len=5) :: '', '', 'rad', 'rad2', &
                                                'rad', 'rad']

contains

  !> units(k): the unit of theta(k) (core units, '-' dimensionless, ''
  !> unknown); input_units(nu), output_units(ny) as the record's channels.
  subroutine param_units(lt, theta, input_units, output_units, units)
    type(layout_table_t), intent(in) :: lt
    real(wp), intent(in) :: theta(:)
    character(len=*), intent(in) :: input_units(:), output_units(:)
    character(len=UNITLEN), intent(out) :: units(:)
    type(dim_t), allocatable :: x(:), u(:), y(:)
    type(dim_t) :: one, sec
    integer :: b, i, j, k

    one%known = .true.
    sec = parse('s')
    u = [dim_t :: (parse(input_units(i)), i=1, size(input_units))]
    y = [dim_t :: (parse(output_units(i)), i=1, size(output_units))]
    x = state_dims(lt, theta, y)
    units = ''
    k = 0
    do b = 1, lt%nblock
      do j = 1, merge(1, lt%cols(b), lt%cols(b) < 0)    ! cols < 0: a vector
        do i = 1, lt%rows(b)
          k = k + 1
          units(k) = text_of(entry_dim(lt%key(b), b, i, j))
        end do
      end do
    end do

  contains

    function entry_dim(key, b, i, j) result(d)
      type(dim_t) :: d
      character(len=*), intent(in) :: key
      integer, intent(in) :: b, i, j
      character(len=5) :: reg
      d = dim_t()
      if (lt%mkind == MODEL_AERO_LONG .and. b <= 3) then
        d = one
        reg = AERO_REG(lt%codes(sum(lt%ncoef(1:b - 1)) + i))
        if (reg /= '') d = over(one, parse(reg))
        return
      end if
      select case (key)
      case ('x0')
        if (i <= size(x)) d = x(i)
      case ('bias')
        d = y(i)
      case ('r')
        d = times(y(i), y(i))
      case ('f')
        if (lt%mkind == MODEL_LINEAR) d = over(x(i), times(sec, x(j)))
      case ('g')
        if (lt%mkind == MODEL_LINEAR) d = over(x(i), times(sec, u(j)))
      case ('bx')
        d = over(x(i), sec)
      case ('delay', 'udelay')
        d = sec
      case ('h')
        if (lt%mkind == MODEL_LINEAR) d = over(y(i), x(j))
      case ('d')
        if (lt%mkind == MODEL_LINEAR) d = over(y(i), u(j))
      end select
    end function entry_dim

  end subroutine param_units

  !> The unit of a/b for two core units ('' if either is unknown): the unit
  !> of an output per unit of an input, for the Bode plot's axis.
  function unit_ratio(a, b) result(text)
    character(len=*), intent(in) :: a, b
    character(len=UNITLEN) :: text
    text = text_of(over(parse(a), parse(b)))
  end function unit_ratio

  !> The states' units: the longitudinal model's own; a linear model's state
  !> i has the unit of the first output whose row of H selects it alone
  !> (a single entry, +-1); otherwise unknown.
  function state_dims(lt, theta, y) result(x)
    type(layout_table_t), intent(in) :: lt
    real(wp), intent(in) :: theta(:)
    type(dim_t), intent(in) :: y(:)
    type(dim_t), allocatable :: x(:)
    integer :: nx, ny, b, i, j
    real(wp), allocatable :: h(:, :)

    b = findloc(lt%key, 'x0', 1)
    nx = lt%rows(b)
    allocate (x(nx))
    if (lt%mkind == MODEL_AERO_LONG) then
      do i = 1, min(nx, size(AERO_STATE))
        x(i) = parse(AERO_STATE(i))
      end do
      return
    end if
    if (lt%mkind /= MODEL_LINEAR) return
    b = findloc(lt%key, 'h', 1)
    ny = lt%rows(b)
    h = reshape(theta(lt%off(b) + 1:lt%off(b) + ny*nx), [ny, nx])
    do j = ny, 1, -1                 ! the first output wins: last written
      if (count(h(j, :) /= 0.0_wp) /= 1) cycle
      i = findloc(h(j, :) /= 0.0_wp, .true., 1)
      if (abs(h(j, i)) == 1.0_wp .and. j <= size(y)) x(i) = y(j)
    end do
  end function state_dims

  !> A core unit ('rad/s', 'm/s2', 'kg/m3', 'Nm'; '' unknown, '-' none).
  function parse(text) result(d)
    type(dim_t) :: d
    character(len=*), intent(in) :: text
    integer :: start, slash, sgn
    d = dim_t()
    if (len_trim(text) == 0) return
    d%known = .true.
    if (trim(text) == '-') return
    start = 1
    sgn = 1
    do
      slash = index(text(start:), '/')
      if (slash == 0) slash = len_trim(text) - start + 2
      if (.not. add_term(text(start:start + slash - 2), sgn)) then
        d%known = .false.
        return
      end if
      start = start + slash
      sgn = -1
      if (start > len_trim(text)) exit
    end do

  contains

    logical function add_term(term, sign) result(ok)
      character(len=*), intent(in) :: term
      integer, intent(in) :: sign
      integer :: n, p, k
      n = len_trim(term)
      p = 1
      if (n > 1 .and. verify(term(n:n), '23') == 0) then
        p = merge(2, 3, term(n:n) == '2')
        n = n - 1
      end if
      ok = term(1:n) == '1'
      if (ok) return
      k = findloc(BASE, term(1:n), 1)
      ok = k > 0
      if (ok) d%e(k) = d%e(k) + sign*p
    end function add_term

  end function parse

  function times(a, b) result(d)
    type(dim_t) :: d
    type(dim_t), intent(in) :: a, b
    d%known = a%known .and. b%known
    d%e = a%e + b%e
  end function times

  function over(a, b) result(d)
    type(dim_t) :: d
    type(dim_t), intent(in) :: a, b
    d%known = a%known .and. b%known
    d%e = a%e - b%e
  end function over

  !> 'rad/s', '1/s2', 'm/(rad.s)': the symbols in BASE order, '-' for none.
  function text_of(d) result(text)
    type(dim_t), intent(in) :: d
    character(len=UNITLEN) :: text
    character(len=UNITLEN) :: num, den
    integer :: nden
    text = ''
    if (.not. d%known) return
    num = powers(d%e)
    den = powers(-d%e)
    nden = count(d%e < 0)
    if (num == '' .and. den == '') then
      text = '-'
    else if (den == '') then
      text = num
    else
      if (num == '') num = '1'
      if (nden > 1) den = '('//trim(den)//')'
      text = trim(num)//'/'//den
    end if
  end function text_of

  !> The positive powers of e as 'rad.s2'.
  function powers(e) result(text)
    integer, intent(in) :: e(NB)
    character(len=UNITLEN) :: text
    character(len=4) :: p
    integer :: k
    text = ''
    do k = 1, NB
      if (e(k) <= 0) cycle
      p = ''
      if (e(k) > 1) write (p, '(i0)') e(k)
      if (text /= '') text = trim(text)//'.'
      text = trim(text)//trim(BASE(k))//trim(p)
    end do
  end function powers

end module mlid_param_units
