!> A model stated as equations in text, with exact Jacobians.
!>
!> Real aircraft need models the built-in kinds cannot state: kinematic
!> equations for flight-path reconstruction, six-degree-of-freedom
!> aerodynamics, stall models.  Here the user writes them in the expression
!> language of mlid_expr and mlid differentiates them exactly (reverse mode,
!> mlid_expr_diff): no Fortran, no rebuild, no finite differences (but for
!> the filter's second derivatives d(dh/dx)/dp, eq_dhdxp).
!>
!> The model's text, one item a line (what iconst carries, as character
!> codes, through the flat interface every kind shares; the deck reader and
!> Python's EquationModel write it):
!>
!>   x NAME = EXPR    a state and its derivative d(NAME)/dt, in state order
!>   y NAME = EXPR    an output, in output order
!>   u NAME           an input, in input order
!>   p NAME           a model parameter, in the order of p
!>   l NAME = EXPR    a definition (a constant or an intermediate quantity),
!>                    usable in the lines after it
!>   t NAME(V1, ...) = B1 ...; B2 ...   a table over up to three variables
!>                    and its breakpoints (mlid_tables): a definition, its
!>                    values parameters NAME[i,j] in the place of the line
!>
!> Expressions read states, inputs, parameters, t (time) and definitions.
!> No process noise enters (nw = 0); there may be no states (nx = 0): the
!> outputs are then functions of inputs and parameters (regression).
module mlid_equations
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t
  use mlid_memory, only: no_memory
  use mlid_expr, only: expr_t, expr_compile, split_definition, is_name, OP_VAR
  use mlid_expr_diff, only: graph_t, program_t, graph_add, graph_node, graph_fold, program_of, &
                            program_forward, program_jacobian, program_values, program_reads, &
                            MAXNODE, MAXVAR
  use mlid_text, only: to_lower, joined, itoa, number_text
  use mlid_tables, only: table_t, table_read, table_graph, table_size, table_value_name, &
                         table_value_text, table_smoothness
  implicit none
  private
  public :: equations_t, equations_create, equations_text_codes, equations_tables, &
            equations_smoothness

  integer, parameter :: NAMELEN = 32
  !> Limits that let the evaluators work in fixed local arrays: variables
  !> (states, inputs, parameters and t: mlid_expr_diff's MAXVAR) and states
  !> or outputs.
  integer, parameter :: MAXOUT = 64

  type, extends(model_t) :: equations_t
    integer :: nvar = 0                                 !< v = [x, u, p, t]
    type(program_t) :: fprog, hprog                     !< state derivatives, outputs
    character(len=NAMELEN), allocatable :: xnames(:), unames(:), pnames(:), ynames(:)
    integer, allocatable :: ystate(:)     !< the state an output is written as (y v = v), or 0
    type(table_t), allocatable :: tables(:)   !< the tables, in the text's order
    integer, allocatable :: tfirst(:)     !< where each table's values start in p
  contains
    procedure :: eval => eq_eval
    procedure :: dfdw => eq_dfdw
    procedure :: dhdxp => eq_dhdxp
    procedure :: has_input_jacobians => eq_input_jacobians
    procedure :: dfdu => eq_dfdu
    procedure :: dhdu => eq_dhdu
    procedure :: fold_inputs => eq_fold_inputs
    procedure :: uses_params => eq_uses_params
    procedure :: measured_states => eq_measured_states
  end type equations_t

  !> One line of the text: its kind letter, name and expression.
  type :: item_t
    character :: kind = ' '
    character(len=NAMELEN) :: name = ''
    character(len=:), allocatable :: rhs
    type(table_t) :: tab                  !< a table's (kind 't')
  end type item_t

contains

  !> Text -> character codes, as iconst carries them.
  pure function equations_text_codes(text) result(codes)
    character(len=*), intent(in) :: text
    integer :: codes(len(text))
    integer :: k
    codes = [(iachar(text(k:k)), k=1, len(text))]
  end function equations_text_codes

  !> The model of the text in iconst (character codes); rconst must be empty.
  subroutine equations_create(iconst, rconst, m, status, msg)
    integer, intent(in) :: iconst(:)
    real(wp), intent(in) :: rconst(:)
    type(equations_t), intent(out) :: m
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(item_t), allocatable :: items(:)

    status = MLID_ERR_INPUT
    if (size(rconst) /= 0) then
      msg = 'equations model: takes no real constants (state them as definitions)'
      return
    end if
    if (any(iconst < 1 .or. iconst > 255)) then
      msg = 'equations model: iconst must hold the text as character codes'
      return
    end if
    call read_items(iconst, items, status, msg)
    if (status /= MLID_OK) return
    call check_size(items, status, msg)     ! before the names: a 200^3 table has 8e6 values
    if (status /= MLID_OK) return
    m%xnames = names_of(items, 'x')
    m%unames = names_of(items, 'u')
    call param_names(items, m, status, msg)
    if (status /= MLID_OK) return
    m%ynames = names_of(items, 'y')
    m%ystate = output_states(items, m%xnames)
    m%nx = size(m%xnames)
    m%nu = size(m%unames)
    m%np = size(m%pnames)
    m%ny = size(m%ynames)
    m%nw = 0
    m%nvar = m%nx + m%nu + m%np + 1
    call compile_all(m, items, status, msg)
  end subroutine equations_create

  !> The model's sizes from its items, refused beyond the fixed limits
  !> (MAXVAR, MAXOUT) or without outputs: counted, nothing allocated.
  subroutine check_size(items, status, msg)
    type(item_t), intent(in) :: items(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer(int64) :: nvar        ! tables of up to 200^3 values each: beyond 32 bits
    integer :: k, nx, ny
    nx = count(items%kind == 'x')
    ny = count(items%kind == 'y')
    nvar = nx + count(items%kind == 'u') + count(items%kind == 'p') + 1
    do k = 1, size(items)
      if (items(k)%kind == 't') nvar = nvar + table_size(items(k)%tab)
    end do
    status = MLID_ERR_INPUT
    if (nvar > MAXVAR .or. nx > MAXOUT .or. ny > MAXOUT) then
      write (msg, '(5(a,i0),a)') 'equations model: too large: ', nvar - 1, ' states, inputs '// &
        'and parameters with the tables'' values (at most ', MAXVAR - 1, '), ', nx, &
        ' states and ', ny, ' outputs (at most ', MAXOUT, ' each)'
    else if (ny == 0) then
      msg = 'equations model: no outputs (lines y NAME = ...)'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine check_size

  !> Split the text into items, checking each line's form and that no name
  !> is used twice.
  subroutine read_items(codes, items, status, msg)
    integer, intent(in) :: codes(:)
    type(item_t), allocatable, intent(out) :: items(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=size(codes)) :: text
    character(len=:), allocatable :: line
    type(item_t) :: it
    integer :: k, a, b

    do k = 1, size(codes)
      text(k:k) = achar(codes(k))
      if (codes(k) == 9 .or. codes(k) == 13) text(k:k) = ' '   ! tabs, CR-LF line ends
    end do
    allocate (items(0))
    status = MLID_OK
    msg = ''
    a = 1
    do while (a <= len(text))
      b = index(text(a:), achar(10))
      b = merge(len(text), a + b - 2, b == 0)
      line = trim(adjustl(text(a:b)))
      a = b + 2
      if (len(line) == 0) cycle
      it%kind = line(1:1)
      it%rhs = ''
      if (len(line) > 2 .and. line(2:2) /= ' ') then
        status = MLID_ERR_INPUT
        msg = 'line '''//line//''' is not x|y|l NAME = ..., u NAME, p NAME or '// &
              't NAME(v) = breakpoints'
      else if (index('xyl', it%kind) > 0 .and. len(line) > 2) then
        call split_definition(line(2:), it%name, it%rhs, status, msg)
      else if (it%kind == 't' .and. len(line) > 2) then
        call table_read(line(2:), it%tab, status, msg)
        it%name = it%tab%name
      else if (index('up', it%kind) > 0 .and. len(line) > 2) then
        it%name = adjustl(line(2:))
        if (.not. is_name(trim(it%name)) .or. len_trim(adjustl(line(2:))) > NAMELEN) then
          status = MLID_ERR_INPUT
          msg = ''''//trim(adjustl(line(2:)))//''' is not a name'
        end if
      else
        status = MLID_ERR_INPUT
        msg = 'line '''//line//''' is not x|y|l NAME = ..., u NAME, p NAME or '// &
              't NAME(v) = breakpoints'
      end if
      if (status == MLID_OK .and. it%kind /= 'y' .and. (it%name == 't' .or. &
          to_lower(it%name) == 'pi' .or. &
          any(items%name == it%name .and. items%kind /= 'y'))) then
        status = MLID_ERR_INPUT
        msg = 'the name '''//trim(it%name)//''' is given twice or reserved (states, inputs, '// &
              'parameters, definitions, t and pi share one set of names)'
      end if
      if (status /= MLID_OK) then
        msg = 'equations model: '//msg
        return
      end if
      call append_item(items, it)
    end do
  end subroutine read_items

  !> The tables' part of a model's p (an equations model's; none of other
  !> kinds): each parameter's text (a table value's with where it is
  !> weighted, mlid_tables' table_value_text; '' for a p line's), and the
  !> smoothness prior's weight w(np, np) of the tables' second differences,
  !> lambda(k) table k's weight (one for each table): finite and >= 0, 0
  !> for no prior on that table (a negative weight would reward roughness,
  !> NaN spoil the fit: refused, never read as none).
  subroutine equations_tables(m, lambda, texts, w, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: lambda(:)
    character(len=*), intent(out) :: texts(:)
    real(wp), intent(out) :: w(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, j, ntab
    texts = ''
    w = 0.0_wp
    status = MLID_OK
    msg = ''
    ntab = 0
    select type (m)
    type is (equations_t)
      ntab = size(m%tables)
      do k = 1, merge(ntab, 0, size(lambda) == ntab)
        if (.not. (ieee_is_finite(lambda(k)) .and. lambda(k) >= 0.0_wp)) then
          status = MLID_ERR_INPUT
          msg = 'smoothness: the weight of table '//trim(m%tables(k)%name)//' is '// &
                number_text(lambda(k))//', not a finite number >= 0 (0: no prior)'
          return
        end if
        do j = 1, table_size(m%tables(k))
          texts(m%tfirst(k) + j - 1) = table_value_text(m%tables(k), j)
        end do
        if (lambda(k) > 0.0_wp) call table_smoothness(m%tables(k), m%tfirst(k) - 1, lambda(k), w)
      end do
      w = 0.5_wp*(w + transpose(w))     ! exactly symmetric: the sums' rounding is not
    end select
    if (size(lambda) /= ntab) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0)') 'smoothness: the model has ', ntab, ' tables, not ', size(lambda)
    end if
  end subroutine equations_tables

  !> The smoothness prior's weight over p (w, np x np) for the tables named:
  !> names(i) with weight lambda(i), the others none (as equations_tables);
  !> a name that is no table of the model, or a model with no tables, is
  !> refused naming it and the tables there are.
  subroutine equations_smoothness(m, names, lambda, w, status, msg)
    class(model_t), intent(in) :: m
    character(len=*), intent(in) :: names(:)
    real(wp), intent(in) :: lambda(:)
    real(wp), intent(out) :: w(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: lam(:)
    character(len=160), allocatable :: texts(:)
    character(len=:), allocatable :: known
    integer :: i, j, k

    w = 0.0_wp
    status = MLID_ERR_INPUT
    msg = 'smoothness: the model has no tables (tables are lines of an equations or sixdof model)'
    select type (m)
    type is (equations_t)
      if (size(m%tables) == 0) return
      known = ''
      do k = 1, size(m%tables)
        known = known//merge(', ', '  ', k > 1)//trim(m%tables(k)%name)
      end do
      allocate (lam(size(m%tables)), texts(m%np), stat=j)
      if (j /= 0) then
        msg = 'smoothness: no memory for the tables'' weights'
        return
      end if
      lam = 0.0_wp
      do i = 1, size(names)
        k = findloc([(m%tables(j)%name == names(i), j=1, size(m%tables))], .true., 1)
        if (k == 0) then
          msg = 'smoothness: no table named '//trim(names(i))//' (tables: '// &
                trim(adjustl(known))//')'
          return
        else if (any(names(1:i - 1) == names(i))) then
          msg = 'smoothness: table '//trim(names(i))//' is given a weight twice'
          return
        end if
        lam(k) = lambda(i)
      end do
      call equations_tables(m, lam, texts, w, status, msg)
    end select
  end subroutine equations_smoothness

  !> items with it after them (not [items, it]: gfortran 12 frees a table's
  !> breakpoints twice in an array constructor of a type that holds them).
  subroutine append_item(items, it)
    type(item_t), allocatable, intent(inout) :: items(:)
    type(item_t), intent(in) :: it
    type(item_t), allocatable :: more(:)
    integer :: k
    allocate (more(size(items) + 1))
    do k = 1, size(items)
      more(k) = items(k)
    end do
    more(size(more)) = it
    call move_alloc(more, items)
  end subroutine append_item

  !> Each output's state when its expression is that state's name alone, else 0.
  pure function output_states(items, xnames) result(ystate)
    type(item_t), intent(in) :: items(:)
    character(len=*), intent(in) :: xnames(:)
    integer, allocatable :: ystate(:)
    integer :: k
    allocate (ystate(0))
    do k = 1, size(items)
      if (items(k)%kind /= 'y') cycle
      ystate = [ystate, findloc(xnames, trim(adjustl(items(k)%rhs)), 1)]
    end do
  end function output_states

  !> Output i is the state it is written as (y theta = theta).
  pure subroutine eq_measured_states(self, p, which, known)
    class(equations_t), intent(in) :: self
    real(wp), intent(in) :: p(:)
    integer, intent(out) :: which(:)
    logical, intent(out) :: known
    which = self%ystate
    known = .true.
  end subroutine eq_measured_states

  !> The parameters' names in the text's order: a p line's name, a table's
  !> values' (NAME[i,j]); and where each table's values start.
  subroutine param_names(items, m, status, msg)
    type(item_t), intent(in) :: items(:)
    type(equations_t), intent(inout) :: m
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, j, ntab, n
    ntab = count(items%kind == 't')
    n = count(items%kind == 'p')
    do k = 1, size(items)
      if (items(k)%kind == 't') n = n + table_size(items(k)%tab)
    end do
    allocate (m%pnames(n), m%tables(ntab), m%tfirst(ntab), stat=status)
    if (status /= 0) then
      call no_memory('the parameters'' names', (NAMELEN*n)/8.0_wp, status, msg)
      return
    end if
    status = MLID_OK
    msg = ''
    ntab = 0
    n = 0
    do k = 1, size(items)
      if (items(k)%kind == 'p') then
        n = n + 1
        m%pnames(n) = items(k)%name
      else if (items(k)%kind == 't') then
        ntab = ntab + 1
        m%tables(ntab) = items(k)%tab
        m%tfirst(ntab) = n + 1
        do j = 1, table_size(items(k)%tab)
          m%pnames(n + j) = table_value_name(items(k)%tab, j)
        end do
        n = n + table_size(items(k)%tab)
      end if
    end do
  end subroutine param_names

  pure function names_of(items, kind) result(names)
    type(item_t), intent(in) :: items(:)
    character, intent(in) :: kind
    character(len=NAMELEN), allocatable :: names(:)
    names = pack(items%name, items%kind == kind)
  end function names_of

  !> Compile the definitions in order, then the state and output equations,
  !> each against [x, u, p, t] and the definitions before it, into one
  !> graph: the programs of the state equations and of the outputs.
  subroutine compile_all(m, items, status, msg)
    type(equations_t), intent(inout) :: m
    type(item_t), intent(in) :: items(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=*), parameter :: WHAT(3) = [character(len=10) :: 'state', 'output', 'definition']
    character(len=NAMELEN), allocatable :: names(:)
    integer, allocatable :: defroot(:), froot(:), hroot(:)
    type(graph_t) :: g
    type(expr_t) :: ex
    integer :: k, root, ntab

    names = [m%xnames, m%unames, m%pnames, [character(len=NAMELEN) :: 't']]
    allocate (defroot(0), froot(0), hroot(0))
    status = MLID_OK
    ntab = 0
    do k = 1, size(items)
      if (items(k)%kind == 't') then
        ntab = ntab + 1
        call table_root(g, items(k)%tab, names, m%nvar, defroot, &
                        m%nx + m%nu + m%tfirst(ntab) - 1, root, status, msg)
        if (status /= MLID_OK) then
          msg = 'equations model, table '//trim(items(k)%name)//': '//msg
          return
        end if
        defroot = [defroot, root]
        names = [names, items(k)%name]
      end if
      if (index('xyl', items(k)%kind) == 0) cycle
      call expr_compile(items(k)%rhs, names, ex, status, msg, noun='variable')
      if (status == MLID_OK) call graph_add(g, ex, m%nvar, defroot, root, status, msg)
      if (status /= MLID_OK) then
        msg = 'equations model, '//trim(WHAT(index('xyl', items(k)%kind)))//' '// &
              trim(items(k)%name)//': '//msg
        return
      end if
      select case (items(k)%kind)
      case ('l')
        defroot = [defroot, root]
        names = [names, items(k)%name]
      case ('x')
        froot = [froot, root]
      case ('y')
        hroot = [hroot, root]
      end select
    end do
    m%fprog = program_of(g, froot, m%nvar)
    m%hprog = program_of(g, hroot, m%nvar)
  end subroutine compile_all

  !> A table's lookup in the graph: its variables' nodes (a variable of v,
  !> or a definition before it, by name: exact, else any case when unique),
  !> its values the variables p0 + 1 ...
  subroutine table_root(g, tab, names, nvar, defroot, p0, root, status, msg)
    type(graph_t), intent(inout) :: g
    type(table_t), intent(in) :: tab
    character(len=*), intent(in) :: names(:)
    integer, intent(in) :: nvar, defroot(:), p0
    integer, intent(out) :: root, status
    character(len=*), intent(out) :: msg
    integer :: vnode(tab%ndim), d, j
    logical :: same(size(names))

    root = 0
    do d = 1, tab%ndim
      same = names == tab%var(d)
      if (count(same) == 0) same = to_lower(names) == to_lower(tab%var(d))
      if (count(same) > 1) then
        status = MLID_ERR_INPUT
        msg = 'its variable '//trim(tab%var(d))//' matches '//itoa(count(same))//' names '// &
              'but for case ('//joined(pack(names, same))//'): write one of them exactly'
        return
      else if (count(same) == 0) then
        status = MLID_ERR_INPUT
        msg = 'no state, input, parameter or definition before it is named '//trim(tab%var(d))
        return
      end if
      j = findloc(same, .true., 1)
      if (j <= nvar) then
        call graph_node(g, OP_VAR, j, 0.0_wp, 0, 0, vnode(d), status, msg)
        if (status /= MLID_OK) return
      else
        vnode(d) = defroot(j - nvar)
      end if
    end do
    call table_graph(g, tab, vnode, p0, root, status, msg)
  end subroutine table_root

  !> The equations with the fixed inputs' values folded in: over one
  !> manoeuvre, b1*m1 + b2*m2 + b3*m3 (m the manoeuvres' indicators) is b1.
  !> Nothing when no input is fixed.
  subroutine eq_fold_inputs(self, fixed, val, folded)
    class(equations_t), intent(in) :: self
    logical, intent(in) :: fixed(:)
    real(wp), intent(in) :: val(:)
    class(model_t), allocatable, intent(out) :: folded
    type(equations_t) :: e
    type(graph_t) :: g
    logical :: vfixed(self%nvar)
    real(wp) :: vval(self%nvar)
    integer :: map(self%fprog%g%n)

    if (.not. any(fixed(1:self%nu))) return
    vfixed = .false.
    vval = 0.0_wp
    vfixed(self%nx + 1:self%nx + self%nu) = fixed(1:self%nu)
    vval(self%nx + 1:self%nx + self%nu) = val(1:self%nu)
    call graph_fold(self%fprog%g, vfixed, vval, g, map)    ! fprog and hprog share one graph
    e = self
    e%fprog = program_of(g, map(self%fprog%root), self%nvar)
    e%hprog = program_of(g, map(self%hprog%root), self%nvar)
    allocate (folded, source=e)
  end subroutine eq_fold_inputs

  pure subroutine eq_uses_params(self, used)
    class(equations_t), intent(in) :: self
    logical, intent(out) :: used(:)
    integer :: k, v
    do k = 1, self%np
      v = self%nx + self%nu + k
      used(k) = program_reads(self%fprog, v) .or. program_reads(self%hprog, v)
    end do
  end subroutine eq_uses_params

  !> v = [x, u, p, t] (fixed size: this runs several times per sample).
  pure subroutine point(self, t, x, u, p, v)
    class(equations_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: v(MAXVAR)
    v(1:self%nx) = x(1:self%nx)
    v(self%nx + 1:self%nx + self%nu) = u(1:self%nu)
    v(self%nx + self%nu + 1:self%nvar - 1) = p(1:self%np)
    v(self%nvar) = t
  end subroutine point

  !> The model at one point (model_t%eval): the state program and the
  !> output program each once, a reverse sweep only for the Jacobians.
  pure subroutine eq_eval(self, t, x, u, p, idx, xdot, a, b, y, c, d)
    class(equations_t), intent(in) :: self
    real(wp), intent(in) :: t, x(self%nx), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out), optional :: xdot(self%nx), a(self%nx, self%nx), b(self%nx, size(idx)), &
                                       y(self%ny), c(self%ny, self%nx), d(self%ny, size(idx))
    real(wp) :: v(MAXVAR)
    call point(self, t, x, u, p, v)
    if (present(a) .or. present(b)) then
      call program_point(self, self%fprog, v, idx, xdot, a, b)
    else if (present(xdot)) then
      call program_values(self%fprog, v(1:self%nvar), xdot(1:self%nx))
    end if
    if (present(c) .or. present(d)) then
      call program_point(self, self%hprog, v, idx, y, c, d)
    else if (present(y)) then
      call program_values(self%hprog, v(1:self%nvar), y(1:self%ny))
    end if
  end subroutine eq_eval

  !> A program's values val, Jacobian dx and parameter Jacobian dp at the
  !> point v, into local arrays for those not asked for (sweep fills all).
  pure subroutine program_point(self, prog, v, idx, val, dx, dp)
    class(equations_t), intent(in) :: self
    type(program_t), intent(in) :: prog
    real(wp), intent(in) :: v(MAXVAR)
    integer, intent(in) :: idx(:)
    real(wp), intent(out), optional :: val(:), dx(:, :), dp(:, :)
    real(wp) :: vl(MAXOUT), dxl(MAXOUT, MAXOUT), dpl(MAXOUT, 0)
    integer :: none(0)
    if (present(dp)) then
      if (present(val) .and. present(dx)) then
        call sweep(self, prog, v, 0, self%nx, idx, val, dx, dp)
      else if (present(val)) then
        call sweep(self, prog, v, 0, self%nx, idx, val, dxl, dp)
      else if (present(dx)) then
        call sweep(self, prog, v, 0, self%nx, idx, vl, dx, dp)
      else
        call sweep(self, prog, v, 0, self%nx, idx, vl, dxl, dp)
      end if
    else if (present(val)) then
      call sweep(self, prog, v, 0, self%nx, none, val, dx, dpl)
    else
      call sweep(self, prog, v, 0, self%nx, none, vl, dx, dpl)
    end if
  end subroutine program_point

  !> Values and partials of a program's expressions: one forward sweep,
  !> then the reverse sweeps: val(i), and jx(i, j) = d/dv(x0 + j) (j = 1 ..
  !> nj: the states, x0 = 0, or the inputs, x0 = nx), jp(i, k) = d/dp(idx(k))
  !> of expression i.
  pure subroutine sweep(self, prog, v, x0, nj, idx, val, jx, jp)
    class(equations_t), intent(in) :: self
    type(program_t), intent(in) :: prog
    real(wp), intent(in) :: v(MAXVAR)               !< the point (mlid_equations' point)
    integer, intent(in) :: x0, nj, idx(:)
    real(wp), intent(out) :: val(:), jx(:, :), jp(:, :)
    real(wp) :: nv(MAXNODE), d1(MAXNODE), d2(MAXNODE)
    integer :: i, nr
    call program_forward(prog, v(1:self%nvar), nv, d1, d2)
    nr = size(prog%root)
    do i = 1, nr                                    ! (a loop: no temporary for prog%root)
      val(i) = nv(prog%root(i))
    end do
    call program_jacobian(prog, d1, d2, x0, jx(1:nr, 1:nj), self%nx + self%nu, idx, &
                          jp(1:nr, 1:size(idx)))
  end subroutine sweep

  pure logical function eq_input_jacobians(self)
    class(equations_t), intent(in) :: self
    eq_input_jacobians = .true.
  end function eq_input_jacobians

  pure subroutine eq_dfdu(self, t, x, u, p, b)
    class(equations_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: b(:, :)
    real(wp) :: v(MAXVAR), val(MAXOUT), none(MAXOUT, 0)
    integer :: noidx(0)
    call point(self, t, x, u, p, v)
    call sweep(self, self%fprog, v, self%nx, self%nu, noidx, val, b, none)   ! the inputs'
  end subroutine eq_dfdu

  pure subroutine eq_dhdu(self, t, x, u, p, b)
    class(equations_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: b(:, :)
    real(wp) :: v(MAXVAR), val(MAXOUT), none(MAXOUT, 0)
    integer :: noidx(0)
    call point(self, t, x, u, p, v)
    call sweep(self, self%hprog, v, self%nx, self%nu, noidx, val, b, none)   ! the inputs'
  end subroutine eq_dhdu

  !> No process noise enters the equations model.
  pure subroutine eq_dfdw(self, t, x, u, p, g)
    class(equations_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: g(:, :)
    g = 0.0_wp
  end subroutine eq_dfdw

  !> d(dh/dx)/dp by central differences of the exact dh/dx (the filter's
  !> covariance partials only; with nw = 0 the filter is output error).
  pure subroutine eq_dhdxp(self, t, x, u, p, idx, dc)
    class(equations_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: dc(:, :, :)
    real(wp) :: pp(size(p)), cp(self%ny, self%nx), cm(self%ny, self%nx), step
    integer :: k
    do k = 1, size(idx)
      step = 1.0e-6_wp*max(1.0_wp, abs(p(idx(k))))
      pp = p
      pp(idx(k)) = p(idx(k)) + step
      call self%dhdx(t, x, u, pp, cp)
      pp(idx(k)) = p(idx(k)) - step
      call self%dhdx(t, x, u, pp, cm)
      dc(:, :, k) = (cp - cm)/(2.0_wp*step)
    end do
  end subroutine eq_dhdxp

end module mlid_equations
