!> The longitudinal model (mlid_aero_long) written out as an equations
!> model (mlid_equations), so that any of its coefficients may be a table
!> (mlid_tables): C_Lalpha over alpha, C_m0 over alpha and V, ...  The same
!> states V, alpha, theta, q, inputs de, F and outputs V, alpha, theta, q,
!> qdot, a_x, a_z, the same equations (mlid_aero_long's header); a
!> parameter keeps its label (C_D0, C_Lalpha, ...) as its name, a table its
!> label as the table's name, its values NAME[i] after the other parameters.
!> What the equations kind lacks: process noise (nw = 0, so filter error
!> with turbulence stays with the longitudinal kind).
module mlid_long_text
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_layout, only: layout_table_t, layout_of, default_label
  use mlid_model_factory, only: MODEL_AERO_LONG
  use mlid_aero_long, only: aero_long_t, aero_long_create, REGRESSOR_NAMES, CONSTANT_SYMBOLS
  implicit none
  private
  public :: longitudinal_text

  character(len=*), parameter :: NL = achar(10)

contains

  !> The equations text of the longitudinal model of iconst, rconst with the
  !> parameters whose labels tables(k) names ('C_Lalpha(alpha) = 0 0.1 0.2',
  !> a table line of mlid_tables after its kind letter) made tables.
  subroutine longitudinal_text(iconst, rconst, tables, text, status, msg)
    integer, intent(in) :: iconst(:)
    real(wp), intent(in) :: rconst(:)
    character(len=*), intent(in) :: tables(:)
    character(len=:), allocatable, intent(out) :: text
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(aero_long_t) :: model
    type(layout_table_t) :: lt
    character(len=32), allocatable :: labels(:)
    character(len=:), allocatable :: params, tabs, coef(:)
    character(len=24) :: num
    integer :: k, j, c, first

    text = ''
    call aero_long_create(iconst, rconst, model, status, msg)   ! its sizes; rconst checked
    if (status == MLID_OK) call layout_of(MODEL_AERO_LONG, model%nx, model%nu, model%ny, &
                                          model%nw, iconst, rconst, lt, status, msg)
    if (status /= MLID_OK) return
    labels = [(default_label(lt, k), k=1, sum(iconst(1:3)))]
    call check_tables(labels, tables, status, msg)
    if (status /= MLID_OK) return
    params = ''
    tabs = ''
    allocate (character(len=4096) :: coef(3))
    coef = ''
    k = 3
    do c = 1, 3
      first = 1
      do j = 1, iconst(c)
        k = k + 1
        if (table_of(labels(k - 3), tables) == 0) then
          params = params//'p '//trim(labels(k - 3))//NL
        else
          tabs = tabs//'t '//trim(adjustl(tables(table_of(labels(k - 3), tables))))//NL
        end if
        coef(c) = trim(coef(c))//trim(merge(' + ', '   ', first == 0))//trim(labels(k - 3))// &
                  '*'//trim(REGRESSOR_NAMES(iconst(k)))     ! each name its expression here
        first = 0
      end do
      if (first == 1) coef(c) = '0'
    end do
    text = 'x V = -Sm*qbar*CD + F*cos(alpha + sigT)/mass + g*sin(alpha - theta)'//NL// &
           'x alpha = -Sm*qbar/V*CL - F*sin(alpha + sigT)/(mass*V) + q + g*cos(alpha - theta)/V'// &
           NL//'x theta = q'//NL//'x q = qdot'//NL
    text = text//'y V = V'//NL//'y alpha = alpha'//NL//'y theta = theta'//NL//'y q = q'//NL// &
           'y qdot = qdot'//NL//'y ax = Sm*qbar*(CL*sin(alpha) - CD*cos(alpha)) + F*cos(sigT)/mass'// &
           NL//'y az = Sm*qbar*(-CL*cos(alpha) - CD*sin(alpha)) - F*sin(sigT)/mass'//NL
    do k = size(CONSTANT_SYMBOLS), 1, -1
      write (num, '(es24.16e3)') rconst(k)
      text = 'l '//trim(CONSTANT_SYMBOLS(k))//' = '//trim(adjustl(num))//NL//text
    end do
    text = 'u de'//NL//'u F'//NL//params//text      ! constants before the tables' variables
    k = index(text, 'x V =')
    text = text(1:k - 1)//'l qhat = q*c2/V0'//NL//tabs//'l CD = '//trim(coef(1))//NL// &
           'l CL = '//trim(coef(2))//NL//'l Cm = '//trim(coef(3))//NL// &
           'l qbar = 0.5*rho*V^2'//NL//'l qdot = ScIy*qbar*Cm + lTIy*F'//NL//text(k:)
  end subroutine longitudinal_text

  !> Each table names a parameter of the model, once.
  subroutine check_tables(labels, tables, status, msg)
    character(len=*), intent(in) :: labels(:), tables(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=len(tables)) :: name
    integer :: k, j
    status = MLID_ERR_INPUT
    do k = 1, size(tables)
      j = scan(tables(k), '(')
      name = ''
      if (j > 1) name = adjustl(tables(k)(1:j - 1))
      if (.not. any(labels == name)) then
        msg = 'longitudinal model: table '''//trim(tables(k))//''' names no coefficient of '// &
              'the model (its labels: C_D0, C_Lalpha, ...)'
        return
      end if
      if (table_of(name, tables(1:k - 1)) > 0) then
        msg = 'longitudinal model: two tables for '//trim(name)
        return
      end if
    end do
    status = MLID_OK
    msg = ''
  end subroutine check_tables

  !> The table that makes parameter label one, or 0.
  pure integer function table_of(label, tables) result(k)
    character(len=*), intent(in) :: label, tables(:)
    integer :: j
    do k = 1, size(tables)
      j = scan(tables(k), '(')
      if (j > 1) then
        if (trim(adjustl(tables(k)(1:j - 1))) == trim(label)) return
      end if
    end do
    k = 0
  end function table_of

end module mlid_long_text
