!> The layout of every model kind's parameter vector
!>   theta = [p, x0, bias, q, r, s, delay, udelay, stab, p0]
!> as a table of blocks (key, rows, columns, offset), with the element name
!> ('f(1,2)', 'x0(3)') and default label ('C_Lalpha', 'M_q.u') of every
!> entry.  The deck reader and, through the flat interface, Python ask this module;
!> no one else knows the order.
module mlid_layout
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: to_lower, to_upper
  use mlid_model_factory, only: MODEL_LINEAR, MODEL_AERO_LONG, MODEL_USER, MODEL_X22, &
                                MODEL_EQUATIONS
  use mlid_equations, only: equations_t, equations_create
  use mlid_x22, only: X22_LABELS
  use mlid_aero_long, only: REGRESSOR_NAMES, NREG
  use mlid_user_model, only: user_model_t, user_model_create
  implicit none
  private
  public :: layout_table_t, layout_table, layout_of, element_index, element_problem, &
            element_name, locate, &
            default_label, block_list, manoeuvre_map, manoeuvre_suffix, NBLOCK

  integer, parameter :: NBLOCK = 16   !< the linear model's blocks, the most any kind has
  !> Suffix of a longitudinal coefficient's default label, per regressor
  !> code (C_D0, C_DV, C_Lalpha, C_mq, ...).
  character(len=8), parameter :: SUFFIX(NREG) = &
    [character(len=8) :: '0', 'V', 'alpha', 'alpha2', 'q', 'de']

  type :: layout_table_t
    integer :: mkind = MODEL_LINEAR
    integer :: nblock = 0, np = 0, nth = 0
    character(len=8) :: key(NBLOCK) = ''
    integer :: rows(NBLOCK) = 0, cols(NBLOCK) = 0, off(NBLOCK) = 0  !< cols < 0: a vector
    integer :: ncoef(3) = 0            !< longitudinal: coefficients of C_D, C_L, C_m
    integer, allocatable :: codes(:)   !< longitudinal: regressor code of each coefficient
    character(len=32), allocatable :: pnames(:)  !< equations: the parameters' own names
  end type layout_table_t

contains

  !> The table of a model kind with these sizes; ncoef: coefficients of C_D,
  !> C_L, C_m (longitudinal, with their regressor codes) or np in ncoef(1)
  !> (user, X-22).
  function layout_table(mkind, nx, nu, ny, nw, ncoef, codes) result(lt)
    integer, intent(in) :: mkind, nx, nu, ny, nw, ncoef(3), codes(:)
    type(layout_table_t) :: lt
    lt%mkind = mkind
    lt%ncoef = ncoef
    lt%codes = codes
    select case (mkind)
    case (MODEL_LINEAR)
      call set_blocks(lt, [character(len=8) :: 'f', 'g', 'h', 'd', 'gamma', 'k', 'bx', 'x0', &
                      'bias', 'q', 'r', 's', 'delay', 'udelay', 'stab', 'p0'], [nx, nx, ny, ny, nx, &
                      nu, nx, nx, ny, nw, ny, nw, ny, nu, nx, nx], [nx, nu, nx, nu, nw, nx, -1, -1, &
                      -1, -1, -1, ny, -1, -1, ny, -1])
    case (MODEL_AERO_LONG)
      call set_blocks(lt, [character(len=8) :: 'cd', 'cl', 'cm', 'x0', 'bias', 'q', 'r', 's', &
                      'delay', 'udelay', 'stab', 'p0'], [ncoef, nx, ny, nw, ny, nw, ny, nu, nx, nx], &
                      [-1, -1, -1, -1, -1, -1, -1, ny, -1, -1, ny, -1])
    case default
      call set_blocks(lt, [character(len=8) :: 'p', 'x0', 'bias', 'q', 'r', 's', 'delay', &
                      'udelay', 'stab', 'p0'], [ncoef(1), nx, ny, nw, ny, nw, ny, nu, nx, nx], &
                      [-1, -1, -1, -1, -1, ny, -1, -1, ny, -1])
    end select
    lt%np = lt%off(findloc(lt%key, 'x0', 1))
  end function layout_table

  !> The table of a model given by its constants, as the flat interface
  !> describes it (longitudinal: iconst = [ncoef, codes]; user: its np).
  subroutine layout_of(mkind, nx, nu, ny, nw, iconst, rconst, lt, status, msg)
    integer, intent(in) :: mkind, nx, nu, ny, nw, iconst(:)
    real(wp), intent(in) :: rconst(:)
    type(layout_table_t), intent(out) :: lt
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(user_model_t) :: user
    type(equations_t) :: eqs
    integer :: ncoef(3)

    status = MLID_OK
    msg = ''
    ncoef = 0
    select case (mkind)
    case (MODEL_AERO_LONG)
      if (size(iconst) < 3) then
        status = MLID_ERR_INPUT
        msg = 'longitudinal model: iconst needs the numbers of coefficients first'
        return
      end if
      ncoef = iconst(1:3)
      if (any(ncoef < 0) .or. sum(ncoef) /= size(iconst) - 3) then
        status = MLID_ERR_INPUT
        msg = 'longitudinal model: iconst must be [ncd, ncl, ncm, one code per coefficient]'
        return
      end if
      lt = layout_table(mkind, nx, nu, ny, nw, ncoef, iconst(4:))
      return
    case (MODEL_USER)
      call user_model_create(iconst, rconst, user, status, msg)
      if (status /= MLID_OK) return
      ncoef(1) = user%np
    case (MODEL_X22)
      ncoef(1) = size(X22_LABELS)
    case (MODEL_EQUATIONS)
      call equations_create(iconst, rconst, eqs, status, msg)
      if (status /= MLID_OK) return
      ncoef(1) = eqs%np
    end select
    lt = layout_table(mkind, nx, nu, ny, nw, ncoef, [integer ::])
    if (mkind == MODEL_EQUATIONS) lt%pnames = eqs%pnames
  end subroutine layout_of

  subroutine set_blocks(lt, keys, rows, cols)
    type(layout_table_t), intent(inout) :: lt
    character(len=*), intent(in) :: keys(:)
    integer, intent(in) :: rows(:), cols(:)
    integer :: b, o
    o = 0
    lt%nblock = size(keys)
    do b = 1, size(keys)
      lt%key(b) = keys(b)
      lt%rows(b) = rows(b)
      lt%cols(b) = cols(b)
      lt%off(b) = o
      o = o + rows(b)*merge(1, cols(b), cols(b) < 0)
    end do
    lt%off(size(keys) + 1:) = o
    lt%nth = o
  end subroutine set_blocks

  !> The block of entry k of theta and the entry's row and column in it.
  subroutine locate(lt, k, b, i, j)
    type(layout_table_t), intent(in) :: lt
    integer, intent(in) :: k
    integer, intent(out) :: b, i, j
    do b = lt%nblock, 1, -1
      if (k > lt%off(b)) exit
    end do
    i = k - lt%off(b)
    j = 0
    if (lt%cols(b) >= 0) then
      j = (i - 1)/lt%rows(b) + 1
      i = i - (j - 1)*lt%rows(b)
    end if
  end subroutine locate

  !> The element name of entry k: key(i) or key(i,j).
  function element_name(lt, k) result(name)
    type(layout_table_t), intent(in) :: lt
    integer, intent(in) :: k
    character(len=32) :: name
    integer :: b, i, j
    call locate(lt, k, b, i, j)
    if (j == 0) then
      write (name, '(a,i0,a)') trim(lt%key(b))//'(', i, ')'
    else
      write (name, '(a,i0,a,i0,a)') trim(lt%key(b))//'(', i, ',', j, ')'
    end if
  end function element_name

  !> The default label of entry k: the element name, or the coefficient's
  !> name (C_D0, C_Lalpha, ... of the longitudinal model; the X-22's M_o.u, ...).
  function default_label(lt, k) result(label)
    type(layout_table_t), intent(in) :: lt
    integer, intent(in) :: k
    character(len=32) :: label
    integer :: b, i, j
    call locate(lt, k, b, i, j)
    label = element_name(lt, k)
    if (lt%mkind == MODEL_AERO_LONG .and. b <= 3) then
      label = 'C_'//trim(merge('D', merge('L', 'm', b == 2), b == 1))// &
              trim(SUFFIX(lt%codes(sum(lt%ncoef(1:b - 1)) + i)))
    else if (lt%mkind == MODEL_X22 .and. b == 1) then
      label = X22_LABELS(i)
    else if (allocated(lt%pnames) .and. b == 1) then
      label = lt%pnames(i)
    end if
  end function default_label

  !> Index into theta of a parameter named key(i) or key(i,j), or (the
  !> equations model) by its own name; 0 if there is no such element.
  integer function element_index(lt, name) result(idx)
    type(layout_table_t), intent(in) :: lt
    character(len=*), intent(in) :: name
    integer :: i, j, b
    character(len=len(name)) :: s, key
    logical :: ok

    idx = 0
    s = to_lower(adjustl(name))
    if (allocated(lt%pnames)) then    ! an equations model's parameter by its name: exact,
      idx = findloc(lt%pnames == adjustl(name), .true., 1)       ! else any case when unique
      if (idx == 0 .and. count(to_lower(lt%pnames) == s) == 1) &
        idx = findloc(to_lower(lt%pnames) == s, .true., 1)
      if (idx > 0) return
    end if
    call parse_element(name, key, i, j, ok)
    if (.not. ok) return
    b = findloc(lt%key(1:lt%nblock), key, 1)
    if (b == 0) return
    if (i < 1 .or. i > lt%rows(b)) return
    if (lt%cols(b) < 0) then
      if (j == 0) idx = lt%off(b) + i
    else if (j >= 1 .and. j <= lt%cols(b)) then
      idx = lt%off(b) + (j - 1)*lt%rows(b) + i
    end if
  end function element_index

  !> Why name is no element of lt, as the front ends say it after
  !> "parameter 'name' "; '' when it is one (element_index).
  function element_problem(lt, name) result(why)
    type(layout_table_t), intent(in) :: lt
    character(len=*), intent(in) :: name
    character(len=512) :: why
    character(len=len(name)) :: key
    integer :: i, j, b
    logical :: ok

    why = ''
    if (element_index(lt, name) > 0) return
    call parse_element(name, key, i, j, ok)
    b = 0
    if (ok) b = findloc(lt%key(1:lt%nblock), key, 1)
    if (b == 0) then
      why = 'does not exist: use'
      do b = 1, lt%nblock
        why = trim(why)//trim(merge(' ', ',', b == 1))//' '//trim(lt%key(b))// &
              trim(merge('(i,j)', '(i)  ', lt%cols(b) >= 0))
      end do
    else if (lt%cols(b) >= 0 .and. j == 0) then
      why = 'needs two indices: '//trim(lt%key(b))//'(i,j)'
    else if (lt%cols(b) >= 0) then
      write (why, '(a,i0,a,i0)') 'does not exist: '//trim(to_upper(lt%key(b)))//' is ', &
        lt%rows(b), 'x', lt%cols(b)
    else
      write (why, '(a,i0,a)') 'does not exist: '//trim(lt%key(b))//' has ', lt%rows(b), ' entries'
    end if
  end function element_problem

  !> name as key(i) or key(i,j): any case, blanks around each part, key of
  !> letters, digits and '_', i and j unsigned integers (j = 0: one index);
  !> ok false when name is not of that form.
  subroutine parse_element(name, key, i, j, ok)
    character(len=*), intent(in) :: name
    character(len=*), intent(out) :: key
    integer, intent(out) :: i, j
    logical, intent(out) :: ok
    character(len=len(name)) :: s
    integer :: p, q, c

    key = ''
    i = 0
    j = 0
    s = to_lower(adjustl(name))
    p = index(s, '(')
    q = len_trim(s)
    ok = p > 1 .and. q > p
    if (.not. ok) return
    ok = s(q:q) == ')'
    key = s(1:p - 1)
    ok = ok .and. len_trim(key) > 0 .and. verify(trim(key), 'abcdefghijklmnopqrstuvwxyz0123456789_') == 0
    if (.not. ok) return
    c = index(s(p + 1:q - 1), ',')
    if (c == 0) then
      call unsigned(s(p + 1:q - 1), i, ok)
    else
      call unsigned(s(p + 1:p + c - 1), i, ok)
      if (ok) call unsigned(s(p + c + 1:q - 1), j, ok)
      ok = ok .and. j > 0
    end if
  end subroutine parse_element

  !> text (blanks around it) as an unsigned integer of at most 9 digits.
  subroutine unsigned(text, n, ok)
    character(len=*), intent(in) :: text
    integer, intent(out) :: n
    logical, intent(out) :: ok
    integer :: ios
    n = 0
    ok = len_trim(adjustl(text)) >= 1 .and. len_trim(adjustl(text)) <= 9
    if (ok) ok = verify(trim(adjustl(text)), '0123456789') == 0
    if (ok) read (text, *, iostat=ios) n
    if (ok) ok = ios == 0
  end subroutine unsigned

  !> theta for nseg manoeuvres: every manoeuvre its own initial state and
  !> biases (the x0 and bias blocks repeated), the rest shared.  Entry k of
  !> the new vector copies entry map(k) of the one-manoeuvre vector and
  !> belongs to manoeuvre seg(k) (0: shared).
  subroutine manoeuvre_map(lt, nseg, map, seg)
    type(layout_table_t), intent(in) :: lt
    integer, intent(in) :: nseg
    integer, allocatable, intent(out) :: map(:), seg(:)
    integer :: bx, bb, j, k, first, last
    bx = findloc(lt%key, 'x0', 1)
    bb = findloc(lt%key, 'bias', 1)
    first = lt%off(bx) + 1                      ! x0 and bias are adjacent
    last = lt%off(bb) + lt%rows(bb)
    map = [(k, k=1, first - 1)]
    seg = [(0, k=1, first - 1)]
    do j = 1, nseg
      map = [map, (k, k=first, lt%off(bb))]
      seg = [seg, (j, k=first, lt%off(bb))]
    end do
    do j = 1, nseg
      map = [map, (k, k=lt%off(bb) + 1, last)]
      seg = [seg, (j, k=lt%off(bb) + 1, last)]
    end do
    map = [map, (k, k=last + 1, lt%nth)]
    seg = [seg, (0, k=last + 1, lt%nth)]
  end subroutine manoeuvre_map

  !> What an entry's label gets after its name on nseg manoeuvres: '#k' for
  !> an entry own to manoeuvre seg = k (manoeuvre_map) when there are
  !> several ('x0(1)#2'), else nothing.
  pure function manoeuvre_suffix(seg, nseg) result(suffix)
    integer, intent(in) :: seg, nseg
    character(len=12) :: suffix
    suffix = ''
    if (seg > 0 .and. nseg > 1) write (suffix, '(a,i0)') '#', seg
  end function manoeuvre_suffix

  !> 'use f(i,j) g(i,j) ... x0(i) ...': the parameters this model has.
  function block_list(lt) result(text)
    type(layout_table_t), intent(in) :: lt
    character(len=:), allocatable :: text
    integer :: b
    text = 'use'
    do b = 1, lt%nblock
      text = text//' '//trim(lt%key(b))//trim(merge('(i,j)', '(i)  ', lt%cols(b) >= 0))
    end do
  end function block_list

end module mlid_layout
