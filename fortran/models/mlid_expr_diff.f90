!> Compiled expressions evaluated at one point, with their exact gradient.
!>
!> The equations model (mlid_equations) states its equations as text in
!> the expression language of mlid_expr.  Here the postfix code of every
!> definition and equation becomes one graph over variables v(1:nvar): a
!> definition is a node like any other, shared by each expression that uses
!> it, so it is computed once per point however often it is used, and so is
!> any subexpression written more than once (same_node).  A
!> program is a set of the graph's expressions (the state equations, or the
!> outputs): one forward sweep gives every node's value and the partials to
!> its operands, one reverse sweep per expression, over its own nodes only,
!> gives its gradient d/dv (reverse-mode differentiation).
module mlid_expr_diff
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_expr, only: expr_t, OP_NUM, OP_VAR, OP_NEG, OP_ADD, OP_SUB, OP_MUL, OP_DIV, &
                       OP_POW, OP_FUN, FUN_ARGS, F_SIN, F_COS, F_TAN, F_ASIN, F_ACOS, F_ATAN, &
                       F_ATAN2, F_SQRT, F_ABS, F_EXP, F_LOG, F_LOG10, F_MIN, F_MAX, F_TANH, F_STEP
  implicit none
  private
  public :: graph_t, program_t, graph_add, graph_node, graph_fold, program_of, program_forward, &
            program_jacobian, program_values, program_reads, MAXNODE, MAXVAR

  !> The most nodes a model's graph may have: the sweeps work in fixed
  !> local arrays, because gfortran puts arrays sized at run time on the
  !> heap, and these run several times per sample.
  integer, parameter :: MAXNODE = 4096
  !> The most variables a program reads (the same fixed local arrays).
  integer, parameter :: MAXVAR = 512

  !> Nodes: op, arg (variable or function number), num (the number of
  !> OP_NUM), c1, c2 the nodes of the operands (earlier ones; 0: none).
  type :: graph_t
    integer :: n = 0
    integer, allocatable :: op(:), arg(:), c1(:), c2(:)
    real(wp), allocatable :: num(:)
  end type graph_t

  !> Expressions of a graph at their roots, as the lists of a forward sweep
  !> over the nodes any of them needs and of a reverse sweep over each one's
  !> own nodes (program_of builds them from the graph).
  type :: program_t
    type(graph_t) :: g
    integer :: nvar = 0                         !< the variables v(1:nvar) it reads
    integer, allocatable :: root(:)
    !> Each expression's reverse sweep as two lists: its operations,
    !> descending, onode(optr(i) : optr(i+1) - 1), and its variables, their
    !> numbers varg and adjoints vloc (vptr likewise): no branch per node.  The
    !> adjoints are the expression's own, nloc(i) of them, numbered by their
    !> node's place among its nodes, descending (its root first): the
    !> operation's oloc, its operands' oc1, oc2 (0: none, a scratch adjoint),
    !> the variable's vloc; so a sweep clears one short run of them, not
    !> scattered entries.
    integer, allocatable :: nloc(:)
    integer, allocatable :: optr(:), onode(:), oloc(:), oc1(:), oc2(:), vptr(:), vloc(:), &
                            varg(:)
    !> The forward sweep in arrays of their own, read at unit stride with no
    !> descriptor between: its leaves first, the variables' nodes lnode
    !> (variable lvar) and the numbers' cnode (value cval), which depend on
    !> nothing; then its tape, the other needed nodes tnode, ascending, with
    !> their operation, operands ta, tb and function tfun (OP_FUN).
    integer, allocatable :: lnode(:), lvar(:), cnode(:), tnode(:), top(:), ta(:), tb(:), &
                            tfun(:)
    real(wp), allocatable :: cval(:)
  end type program_t

contains

  !> Append ex, compiled against [v(1:nvar), definitions]: a reference to
  !> definition k (variable nvar + k) is the node defroot(k) itself.  root:
  !> the expression's node.  Fails when the graph would pass MAXNODE.
  subroutine graph_add(g, ex, nvar, defroot, root, status, msg)
    type(graph_t), intent(inout) :: g
    type(expr_t), intent(in) :: ex
    integer, intent(in) :: nvar, defroot(:)
    integer, intent(out) :: root, status
    character(len=*), intent(out) :: msg
    integer :: st(ex%n), k, top, nargs, a, b

    root = 0
    status = MLID_ERR_INPUT
    if (g%n + ex%n > MAXNODE) then
      write (msg, '(a,i0,a)') 'the equations and definitions together pass ', MAXNODE, &
        ' operations'
      return
    end if
    if (.not. allocated(g%op)) allocate (g%op(0), g%arg(0), g%c1(0), g%c2(0), g%num(0))
    call reserve(g, g%n + ex%n)
    top = 0
    do k = 1, ex%n
      if (ex%op(k) == OP_VAR .and. ex%arg(k) > nvar) then
        top = top + 1
        st(top) = defroot(ex%arg(k) - nvar)
        cycle
      end if
      select case (ex%op(k))
      case (OP_NUM, OP_VAR)
        nargs = 0
      case (OP_NEG)
        nargs = 1
      case (OP_FUN)
        nargs = FUN_ARGS(ex%arg(k))
      case default
        nargs = 2
      end select
      a = 0
      b = 0
      if (nargs >= 1) a = st(top - nargs + 1)
      if (nargs == 2) b = st(top)
      top = top - nargs + 1
      st(top) = same_node(g, ex%op(k), ex%arg(k), ex%num(k), a, b)
      if (st(top) > 0) cycle              ! computed already: shared
      g%n = g%n + 1
      g%op(g%n) = ex%op(k)
      g%arg(g%n) = ex%arg(k)
      g%num(g%n) = ex%num(k)
      g%c1(g%n) = a
      g%c2(g%n) = b
      st(top) = g%n
    end do
    root = st(top)
    status = MLID_OK
    msg = ''
  end subroutine graph_add

  !> k: the node op(arg, num) of operands a, b (nodes of g, 0: none), the one
  !> there is or a new one: a caller that builds an expression node by node
  !> (a table lookup, mlid_tables).  Fails when the graph would pass MAXNODE.
  subroutine graph_node(g, op, arg, num, a, b, k, status, msg)
    type(graph_t), intent(inout) :: g
    integer, intent(in) :: op, arg, a, b
    real(wp), intent(in) :: num
    integer, intent(out) :: k, status
    character(len=*), intent(out) :: msg
    k = 0
    status = MLID_OK
    msg = ''
    if (.not. allocated(g%op)) allocate (g%op(0), g%arg(0), g%c1(0), g%c2(0), g%num(0))
    if (g%n >= MAXNODE) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a)') 'the equations, definitions and tables together pass ', MAXNODE, &
        ' operations'
      return
    end if
    if (size(g%op) <= g%n) call reserve(g, 2*g%n + 16)     ! room ahead: not one at a time
    call add_node(g, op, arg, num, a, b, k)
  end subroutine graph_node

  !> The node that computes op(arg, num) of nodes a, b already, or 0: a
  !> subexpression written twice (sin(theta) in three state equations) is
  !> computed once.
  pure integer function same_node(g, op, arg, num, a, b) result(k)
    type(graph_t), intent(in) :: g
    integer, intent(in) :: op, arg, a, b
    real(wp), intent(in) :: num
    do k = 1, g%n
      if (g%op(k) == op .and. g%arg(k) == arg .and. g%c1(k) == a .and. g%c2(k) == b .and. &
          (op /= OP_NUM .or. g%num(k) == num)) return
    end do
    k = 0
  end function same_node

  !> Room for n nodes.
  pure subroutine reserve(g, n)
    type(graph_t), intent(inout) :: g
    integer, intent(in) :: n
    integer :: extra
    extra = n - size(g%op)
    if (extra <= 0) return
    g%op = [g%op, spread(0, 1, extra)]
    g%arg = [g%arg, spread(0, 1, extra)]
    g%c1 = [g%c1, spread(0, 1, extra)]
    g%c2 = [g%c2, spread(0, 1, extra)]
    g%num = [g%num, spread(0.0_wp, 1, extra)]
  end subroutine reserve

  !> The graph with the variables marked fixed replaced by their values val
  !> and the constants folded: a node of constants becomes a constant, x*0
  !> and 0*x become 0, x*1, 1*x, x+0, 0+x, x-0 and x/1 become x, 0-x becomes
  !> -x.  Node k of g is node map(k) of gf.  Values and gradients are those
  !> of g up to rounding (where folding merges two nodes, their adjoints add
  !> in another order; x+0 -> x keeps the sign of a zero x), except that a
  !> zero factor also drops an operand that is not finite: the fixed
  !> variables are inputs known over a stretch of record, such as a
  !> manoeuvre's indicator.
  pure subroutine graph_fold(g, fixed, val, gf, map)
    type(graph_t), intent(in) :: g
    logical, intent(in) :: fixed(:)
    real(wp), intent(in) :: val(:)
    type(graph_t), intent(out) :: gf
    integer, intent(out) :: map(:)
    integer :: k, a, b

    allocate (gf%op(0), gf%arg(0), gf%c1(0), gf%c2(0), gf%num(0))
    call reserve(gf, g%n)
    do k = 1, g%n
      a = 0
      b = 0
      if (g%c1(k) > 0) a = map(g%c1(k))
      if (g%c2(k) > 0) b = map(g%c2(k))
      if (g%op(k) == OP_VAR) then                 ! (no short circuit in Fortran)
        if (fixed(g%arg(k))) then
          call add_node(gf, OP_NUM, 0, val(g%arg(k)), 0, 0, map(k))
        else
          call add_node(gf, OP_VAR, g%arg(k), 0.0_wp, 0, 0, map(k))
        end if
      else if (g%op(k) /= OP_NUM .and. is(a) .and. &
               (b == 0 .or. is(b))) then
        call add_node(gf, OP_NUM, 0, constant(g%op(k), g%arg(k), gf%num(a), num_of(b)), 0, 0, &
                      map(k))
      else if (is(a, 0.0_wp) .and. g%op(k) == OP_SUB) then
        call add_node(gf, OP_NEG, 0, 0.0_wp, b, 0, map(k))
      else if ((is(a, 0.0_wp) .or. is(b, 0.0_wp)) .and. g%op(k) == OP_MUL) then
        call add_node(gf, OP_NUM, 0, 0.0_wp, 0, 0, map(k))
      else if ((is(a, 1.0_wp) .and. g%op(k) == OP_MUL) .or. &
               (is(a, 0.0_wp) .and. g%op(k) == OP_ADD)) then
        map(k) = b
      else if ((is(b, 1.0_wp) .and. (g%op(k) == OP_MUL .or. g%op(k) == OP_DIV)) .or. &
               (is(b, 0.0_wp) .and. (g%op(k) == OP_ADD .or. g%op(k) == OP_SUB))) then
        map(k) = a
      else
        call add_node(gf, g%op(k), g%arg(k), g%num(k), a, b, map(k))
      end if
    end do

  contains

    !> Whether folded node j is a constant (equal to c, if given).
    pure logical function is(j, c)
      integer, intent(in) :: j
      real(wp), intent(in), optional :: c
      is = .false.
      if (j > 0) is = gf%op(j) == OP_NUM
      if (is .and. present(c)) is = gf%num(j) == c
    end function is

    pure real(wp) function num_of(j)
      integer, intent(in) :: j
      num_of = 0.0_wp
      if (j > 0) num_of = gf%num(j)
    end function num_of

  end subroutine graph_fold

  !> k: the node op(arg, num) of operands a, b in g, the one there is or a new one.
  pure subroutine add_node(g, op, arg, num, a, b, k)
    type(graph_t), intent(inout) :: g
    integer, intent(in) :: op, arg, a, b
    real(wp), intent(in) :: num
    integer, intent(out) :: k
    k = same_node(g, op, arg, num, a, b)
    if (k > 0) return
    call reserve(g, g%n + 1)
    g%n = g%n + 1
    k = g%n
    g%op(k) = op
    g%arg(k) = arg
    g%num(k) = num
    g%c1(k) = a
    g%c2(k) = b
  end subroutine add_node

  !> The value of op on constants, computed as forward_tape does.
  pure real(wp) function constant(op, arg, a, b) result(c)
    integer, intent(in) :: op, arg
    real(wp), intent(in) :: a, b
    real(wp) :: da, db
    select case (op)
    case (OP_NEG)
      c = -a
    case (OP_ADD)
      c = a + b
    case (OP_SUB)
      c = a - b
    case (OP_MUL)
      c = a*b
    case (OP_FUN)
      if (FUN_ARGS(arg) == 2) then
        call fun2(arg, a, b, c, da, db)
      else
        call fun1(arg, a, c, da)
      end if
    case default
      call binary(op, a, b, c, da, db)
    end select
  end function constant

  !> Whether the program reads variable v (a node of it is v).
  pure logical function program_reads(p, v)
    type(program_t), intent(in) :: p
    integer, intent(in) :: v
    program_reads = any(p%lvar == v)
  end function program_reads

  !> The program of the graph's expressions at the nodes roots, over nvar
  !> variables.
  pure function program_of(g, roots, nvar) result(p)
    type(graph_t), intent(in) :: g
    integer, intent(in) :: roots(:), nvar
    type(program_t) :: p
    logical :: need(g%n), any_need(g%n)
    integer, allocatable :: ridx(:), rptr(:)
    integer :: i, k
    p%g = g
    p%nvar = nvar
    p%root = roots
    ! each root's nodes, descending: ridx(rptr(i) : rptr(i+1) - 1)
    allocate (rptr(size(roots) + 1), ridx(0))
    any_need = .false.
    rptr(1) = 1
    do i = 1, size(roots)
      need = .false.
      need(roots(i)) = .true.
      do k = roots(i), 1, -1            ! operands come before their node
        if (.not. need(k)) cycle
        if (g%c1(k) > 0) need(g%c1(k)) = .true.
        if (g%c2(k) > 0) need(g%c2(k)) = .true.
      end do
      ridx = [ridx, pack([(k, k=g%n, 1, -1)], need(g%n:1:-1))]
      rptr(i + 1) = size(ridx) + 1
      any_need = any_need .or. need
    end do
    call forward_lists(g, pack([(k, k=1, g%n)], any_need), p)
    call reverse_lists(g, ridx, rptr, p)
  end function program_of

  !> The forward sweep's lists (program_t's lnode .. tfun) from the needed
  !> nodes fwd, ascending, each array allocated once (this runs for every
  !> manoeuvre's folded model at every evaluation).
  pure subroutine forward_lists(g, fwd, p)
    type(graph_t), intent(in) :: g
    integer, intent(in) :: fwd(:)
    type(program_t), intent(inout) :: p
    integer :: nl, nc, nt, j, k
    nl = count_op(g, fwd, OP_VAR)
    nc = count_op(g, fwd, OP_NUM)
    nt = size(fwd) - nl - nc
    allocate (p%lnode(nl), p%lvar(nl), p%cnode(nc), p%cval(nc), p%tnode(nt), p%top(nt), &
              p%ta(nt), p%tb(nt), p%tfun(nt))
    nl = 0
    nc = 0
    nt = 0
    do j = 1, size(fwd)
      k = fwd(j)
      select case (g%op(k))
      case (OP_VAR)
        nl = nl + 1
        p%lnode(nl) = k
        p%lvar(nl) = g%arg(k)
      case (OP_NUM)
        nc = nc + 1
        p%cnode(nc) = k
        p%cval(nc) = g%num(k)
      case default
        nt = nt + 1
        p%tnode(nt) = k
        p%top(nt) = g%op(k)
        p%ta(nt) = g%c1(k)
        p%tb(nt) = g%c2(k)
        p%tfun(nt) = g%arg(k)
      end select
    end do
  end subroutine forward_lists

  !> Each expression's reverse lists (program_t's nloc .. varg) from its
  !> nodes, descending, ridx(rptr(i) : rptr(i+1) - 1), each array allocated
  !> once: its adjoints numbered by their node's place in that list (loc).
  pure subroutine reverse_lists(g, ridx, rptr, p)
    type(graph_t), intent(in) :: g
    integer, intent(in) :: ridx(:), rptr(:)
    type(program_t), intent(inout) :: p
    integer :: loc(0:g%n), nvn, nop, i, j, k
    nvn = count_op(g, ridx, OP_VAR)
    nop = size(ridx) - nvn - count_op(g, ridx, OP_NUM)
    allocate (p%optr(size(p%root) + 1), p%vptr(size(p%root) + 1), p%onode(nop), p%oloc(nop), &
              p%oc1(nop), p%oc2(nop), p%vloc(nvn), p%varg(nvn))
    p%nloc = rptr(2:) - rptr(:size(rptr) - 1)
    loc(0) = 0                                 ! an operand 0 (none): the scratch adjoint
    p%optr(1) = 1
    p%vptr(1) = 1
    do i = 1, size(p%root)
      nop = p%optr(i) - 1
      nvn = p%vptr(i) - 1
      do j = rptr(i), rptr(i + 1) - 1
        loc(ridx(j)) = j - rptr(i) + 1
      end do
      do j = rptr(i), rptr(i + 1) - 1
        k = ridx(j)
        select case (g%op(k))
        case (OP_NUM)
        case (OP_VAR)
          nvn = nvn + 1
          p%vloc(nvn) = loc(k)
          p%varg(nvn) = g%arg(k)
        case default
          nop = nop + 1
          p%onode(nop) = k
          p%oloc(nop) = loc(k)
          p%oc1(nop) = loc(g%c1(k))
          p%oc2(nop) = loc(g%c2(k))
        end select
      end do
      p%optr(i + 1) = nop + 1
      p%vptr(i + 1) = nvn + 1
    end do
  end subroutine reverse_lists

  !> How many of the nodes have the operation op (a loop: g%op(nodes)
  !> would take a temporary).
  pure integer function count_op(g, nodes, op) result(n)
    type(graph_t), intent(in) :: g
    integer, intent(in) :: nodes(:), op
    integer :: j
    n = 0
    do j = 1, size(nodes)
      if (g%op(nodes(j)) == op) n = n + 1
    end do
  end function count_op

  !> Every needed node's value nv and partials to its operands d1, d2.
  pure subroutine program_forward(p, v, nv, d1, d2)
    type(program_t), intent(in) :: p
    real(wp), intent(in) :: v(p%nvar)      ! (explicit: passed on as it is, never packed)
    real(wp), intent(out) :: nv(MAXNODE), d1(MAXNODE), d2(MAXNODE)
    call leaves(size(p%lnode), p%lnode, p%lvar, p%nvar, v, size(p%cnode), p%cnode, p%cval, nv)
    call forward_tape(size(p%tnode), p%tnode, p%top, p%ta, p%tb, p%tfun, nv, d1, d2)
  end subroutine program_forward

  !> The leaves' values: the variables' nodes and the numbers'.
  pure subroutine leaves(nl, lnode, lvar, nvar, v, nc, cnode, cval, nv)
    integer, intent(in) :: nl, lnode(nl), lvar(nl), nvar, nc, cnode(nc)
    real(wp), intent(in) :: v(nvar), cval(nc)
    real(wp), intent(inout) :: nv(MAXNODE)
    integer :: j
    do j = 1, nl
      nv(lnode(j)) = v(lvar(j))
    end do
    do j = 1, nc
      nv(cnode(j)) = cval(j)
    end do
  end subroutine leaves

  !> program_forward over its tape, after the leaves (explicit shapes: the
  !> loop reads plain arrays).  Entries of other nodes are left as they are.
  pure subroutine forward_tape(n, node, op, a, b, fun, nv, d1, d2)
    integer, intent(in) :: n, node(n), op(n), a(n), b(n), fun(n)
    real(wp), intent(inout) :: nv(MAXNODE), d1(MAXNODE), d2(MAXNODE)
    integer :: j, k

    do j = 1, n
      k = node(j)
      select case (op(j))
      case (OP_NEG)
        nv(k) = -nv(a(j))
        d1(k) = -1.0_wp
        d2(k) = 0.0_wp                 ! an operation of one operand: d2 for the sweep's scratch
      case (OP_ADD)                   ! the common operations inline, the rest in helpers
        nv(k) = nv(a(j)) + nv(b(j))
        d1(k) = 1.0_wp
        d2(k) = 1.0_wp
      case (OP_SUB)
        nv(k) = nv(a(j)) - nv(b(j))
        d1(k) = 1.0_wp
        d2(k) = -1.0_wp
      case (OP_MUL)
        nv(k) = nv(a(j))*nv(b(j))
        d1(k) = nv(b(j))
        d2(k) = nv(a(j))
      case (OP_FUN)
        if (b(j) > 0) then
          call fun2(fun(j), nv(a(j)), nv(b(j)), nv(k), d1(k), d2(k))
        else
          call fun1(fun(j), nv(a(j)), nv(k), d1(k))
          d2(k) = 0.0_wp
        end if
      case default
        call binary(op(j), nv(a(j)), nv(b(j)), nv(k), d1(k), d2(k))
      end select
    end do
  end subroutine forward_tape

  !> The partials of the program's expressions after program_forward (d1,
  !> d2): jx(i, j) = d expression i / d v(x0 + j), a run of variables (the
  !> states, say), and jp(i, k) = d expression i / d v(p0 + idx(k)) (the
  !> parameters idx; one may come twice: a tie of several terms).  One
  !> reverse sweep each expression, over its own nodes, its adjoints local
  !> (its root the first).  (One sweep for all, an adjoint per expression,
  !> was slower even where the expressions share most of their nodes: test
  !> case 27's 593 against 364 M instructions a fit, a six-degree-of-freedom
  !> fit's 974 against 695 M.)
  pure subroutine program_jacobian(p, d1, d2, x0, jx, p0, idx, jp)
    type(program_t), intent(in) :: p
    real(wp), intent(in) :: d1(MAXNODE), d2(MAXNODE)
    integer, intent(in) :: x0, p0, idx(:)
    real(wp), intent(out) :: jx(:, :), jp(:, :)
    real(wp) :: adj(0:MAXNODE), a, g(MAXVAR)
    integer :: i, j, k

    g(1:p%nvar) = 0.0_wp        ! an expression's gradient, back to zero after each
    do i = 1, size(p%root)
      adj(0:p%nloc(i)) = 0.0_wp      ! 0: the scratch of one-operand operations
      adj(1) = 1.0_wp
      do j = p%optr(i), p%optr(i + 1) - 1
        k = p%onode(j)
        a = adj(p%oloc(j))
        ! a node the expression does not depend on passes nothing on, even
        ! where its partial is infinite (sqrt at 0): a select, not a branch
        adj(p%oc1(j)) = adj(p%oc1(j)) + merge(a*d1(k), 0.0_wp, a /= 0.0_wp)
        adj(p%oc2(j)) = adj(p%oc2(j)) + merge(a*d2(k), 0.0_wp, a /= 0.0_wp)
      end do
      do j = p%vptr(i), p%vptr(i + 1) - 1          ! a variable is one node (same_node)
        g(p%varg(j)) = adj(p%vloc(j))
      end do
      do j = 1, size(jx, 2)
        jx(i, j) = g(x0 + j)
      end do
      do j = 1, size(idx)
        jp(i, j) = g(p0 + idx(j))
      end do
      do j = p%vptr(i), p%vptr(i + 1) - 1
        g(p%varg(j)) = 0.0_wp
      end do
    end do
  end subroutine program_jacobian


  !> The values of the program's expressions at v.
  pure subroutine program_values(p, v, val)
    type(program_t), intent(in) :: p
    real(wp), intent(in) :: v(p%nvar)
    real(wp), intent(out) :: val(:)
    real(wp) :: nv(MAXNODE), d1(MAXNODE), d2(MAXNODE)
    integer :: i
    call program_forward(p, v, nv, d1, d2)
    do i = 1, size(p%root)          ! (a loop: the vector subscript would take a temporary)
      val(i) = nv(p%root(i))
    end do
  end subroutine program_values

  !> c = a op b and the partials dc/da, dc/db.
  pure subroutine binary(op, a, b, c, da, db)
    integer, intent(in) :: op
    real(wp), intent(in) :: a, b
    real(wp), intent(out) :: c, da, db
    select case (op)                  ! + - * are inline in forward_tape
    case (OP_DIV)
      c = a/b
      da = 1.0_wp/b
      db = -c/b
    case (OP_POW)
      if (b == 2.0_wp) then
        c = a*a
        da = 2.0_wp*a
      else if (b == 0.0_wp) then
        c = 1.0_wp                              ! a^0, also at a = 0
        da = 0.0_wp
      else if (b == anint(b) .and. abs(b) < 1.0e6_wp) then
        c = a**nint(b)                          ! integer powers of negative numbers too
        da = b*a**(nint(b) - 1)
      else
        c = a**b
        da = b*a**(b - 1.0_wp)
      end if
      db = 0.0_wp
      if (a > 0.0_wp) db = c*log(a)
    case default                    ! none: the parser makes no other (NaN shows it at once)
      c = ieee_value(c, ieee_quiet_nan)
      da = c
      db = c
    end select
  end subroutine binary

  !> c = f(a) and dc/da.
  pure subroutine fun1(f, a, c, da)
    integer, intent(in) :: f
    real(wp), intent(in) :: a
    real(wp), intent(out) :: c, da
    select case (f)
    case (F_SIN)
      c = sin(a)
      da = cos(a)
    case (F_COS)
      c = cos(a)
      da = -sin(a)
    case (F_TAN)
      c = tan(a)
      da = 1.0_wp + c*c
    case (F_ASIN)
      c = asin(a)
      da = 1.0_wp/sqrt(1.0_wp - a*a)
    case (F_ACOS)
      c = acos(a)
      da = -1.0_wp/sqrt(1.0_wp - a*a)
    case (F_ATAN)
      c = atan(a)
      da = 1.0_wp/(1.0_wp + a*a)
    case (F_SQRT)
      c = sqrt(a)
      da = 0.5_wp/c
    case (F_ABS)
      c = abs(a)
      da = sign(1.0_wp, a)
    case (F_EXP)
      c = exp(a)
      da = c
    case (F_LOG)
      c = log(a)
      da = 1.0_wp/a
    case (F_LOG10)
      c = log10(a)
      da = 1.0_wp/(a*log(10.0_wp))
    case (F_TANH)
      c = tanh(a)
      da = 1.0_wp - c*c
    case (F_STEP)                     ! a switch: flat on either side
      c = merge(1.0_wp, 0.0_wp, a > 0.0_wp)
      da = 0.0_wp
    case default                    ! none: every function of mlid_expr is above
      c = ieee_value(c, ieee_quiet_nan)
      da = c
    end select
  end subroutine fun1

  !> c = f(a, b) and its partials (atan2(a, b) = the angle of (b, a)).
  pure subroutine fun2(f, a, b, c, da, db)
    integer, intent(in) :: f
    real(wp), intent(in) :: a, b
    real(wp), intent(out) :: c, da, db
    real(wp) :: r2
    select case (f)
    case (F_ATAN2)
      c = atan2(a, b)
      r2 = a*a + b*b
      da = b/r2
      db = -a/r2
    case (F_MIN)
      c = min(a, b)
      da = merge(1.0_wp, 0.0_wp, a <= b)
      db = 1.0_wp - da
    case (F_MAX)
      c = max(a, b)
      da = merge(1.0_wp, 0.0_wp, a >= b)
      db = 1.0_wp - da
    case default                    ! none: every function of mlid_expr is above
      c = ieee_value(c, ieee_quiet_nan)
      da = c
      db = c
    end select
  end subroutine fun2

end module mlid_expr_diff
