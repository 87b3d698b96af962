!> Compiled expressions evaluated at one point, with their exact gradient.
!>
!> The equations model (mlid_equations) states its equations as text in
!> the expression language of mlid_expr.  Here that postfix code becomes a
!> code_t over variables v(1:nvar), with named definitions expanded in
!> place, and is evaluated at a point: the value alone, or the value and
!> the gradient d/dv by one forward and one reverse sweep (reverse-mode
!> differentiation), which costs a few evaluations whatever nvar is.
module mlid_expr_diff
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp
  use mlid_expr, only: expr_t, OP_NUM, OP_VAR, OP_NEG, OP_ADD, OP_SUB, OP_MUL, OP_DIV, &
                       OP_POW, OP_FUN, FUN_ARGS, F_SIN, F_COS, F_TAN, F_ASIN, F_ACOS, F_ATAN, &
                       F_ATAN2, F_SQRT, F_ABS, F_EXP, F_LOG, F_LOG10, F_MIN, F_MAX, F_TANH, F_STEP
  implicit none
  private
  public :: code_t, code_expand, code_value, code_gradient, MAXNODE, MAXDEPTH

  !> The longest code and the deepest stack one may need: the evaluators
  !> work in fixed local arrays, because gfortran puts arrays sized at run
  !> time on the heap, and these run several times per sample.
  integer, parameter :: MAXNODE = 2048, MAXDEPTH = 256

  !> Postfix code over v(1:nvar): op, arg (variable or function number),
  !> num (the number of OP_NUM); c1, c2 the nodes of a node's operands
  !> (0: none); depth, the stack it needs.
  type :: code_t
    integer :: n = 0, depth = 0
    integer, allocatable :: op(:), arg(:), c1(:), c2(:)
    real(wp), allocatable :: num(:)
  end type code_t

contains

  !> ex compiled against [v(1:nvar), definitions(:)] -> code over v alone:
  !> each reference to definition k (name nvar + k) is replaced by defs(k).
  subroutine code_expand(ex, nvar, defs, code)
    type(expr_t), intent(in) :: ex
    integer, intent(in) :: nvar
    type(code_t), intent(in) :: defs(:)
    type(code_t), intent(out) :: code
    integer :: k, d, m

    m = 0
    do k = 1, ex%n
      if (ex%op(k) == OP_VAR .and. ex%arg(k) > nvar) then
        m = m + defs(ex%arg(k) - nvar)%n
      else
        m = m + 1
      end if
    end do
    allocate (code%op(m), code%arg(m), code%num(m))
    code%n = 0
    do k = 1, ex%n
      if (ex%op(k) == OP_VAR .and. ex%arg(k) > nvar) then
        d = ex%arg(k) - nvar
        code%op(code%n + 1:code%n + defs(d)%n) = defs(d)%op(1:defs(d)%n)
        code%arg(code%n + 1:code%n + defs(d)%n) = defs(d)%arg(1:defs(d)%n)
        code%num(code%n + 1:code%n + defs(d)%n) = defs(d)%num(1:defs(d)%n)
        code%n = code%n + defs(d)%n
      else
        code%n = code%n + 1
        code%op(code%n) = ex%op(k)
        code%arg(code%n) = ex%arg(k)
        code%num(code%n) = ex%num(k)
      end if
    end do
    call link(code)
  end subroutine code_expand

  !> Each node's operands (c1, c2) and the stack the code needs.
  pure subroutine link(code)
    type(code_t), intent(inout) :: code
    integer :: st(code%n), k, top
    allocate (code%c1(code%n), code%c2(code%n))
    code%c1 = 0
    code%c2 = 0
    code%depth = 0
    top = 0
    do k = 1, code%n
      select case (code%op(k))
      case (OP_NUM, OP_VAR)
        top = top + 1
      case (OP_NEG)
        code%c1(k) = st(top)
      case (OP_FUN)
        if (FUN_ARGS(code%arg(k)) == 2) then
          code%c1(k) = st(top - 1)
          code%c2(k) = st(top)
          top = top - 1
        else
          code%c1(k) = st(top)
        end if
      case default
        code%c1(k) = st(top - 1)
        code%c2(k) = st(top)
        top = top - 1
      end select
      st(top) = k
      code%depth = max(code%depth, top)
    end do
  end subroutine link

  !> The value of the code at v.
  pure real(wp) function code_value(code, v) result(val)
    type(code_t), intent(in) :: code
    real(wp), intent(in) :: v(:)
    real(wp) :: nv(MAXNODE), d1, d2
    integer :: k

    do k = 1, code%n
      select case (code%op(k))
      case (OP_NUM)
        nv(k) = code%num(k)
      case (OP_VAR)
        nv(k) = v(code%arg(k))
      case (OP_NEG)
        nv(k) = -nv(code%c1(k))
      case (OP_ADD)
        nv(k) = nv(code%c1(k)) + nv(code%c2(k))
      case (OP_SUB)
        nv(k) = nv(code%c1(k)) - nv(code%c2(k))
      case (OP_MUL)
        nv(k) = nv(code%c1(k))*nv(code%c2(k))
      case (OP_FUN)
        if (code%c2(k) > 0) then
          call fun2(code%arg(k), nv(code%c1(k)), nv(code%c2(k)), nv(k), d1, d2)
        else
          call fun1(code%arg(k), nv(code%c1(k)), nv(k), d1)
        end if
      case default
        call binary(code%op(k), nv(code%c1(k)), nv(code%c2(k)), nv(k), d1, d2)
      end select
    end do
    val = nv(code%n)
  end function code_value

  !> The value of the code at v and its gradient g = d(value)/dv: a forward
  !> sweep keeps each node's value and the partials to its operands, a
  !> reverse sweep carries the adjoints down to the variables.
  pure subroutine code_gradient(code, v, val, g)
    type(code_t), intent(in) :: code
    real(wp), intent(in) :: v(:)
    real(wp), intent(out) :: val, g(:)
    real(wp) :: nv(MAXNODE), d1(MAXNODE), d2(MAXNODE), adj(MAXNODE)
    integer :: k, n

    n = code%n
    do k = 1, n
      select case (code%op(k))
      case (OP_NUM)
        nv(k) = code%num(k)
      case (OP_VAR)
        nv(k) = v(code%arg(k))
      case (OP_NEG)
        nv(k) = -nv(code%c1(k))
        d1(k) = -1.0_wp
      case (OP_ADD)                   ! the common operations inline, the rest in helpers
        nv(k) = nv(code%c1(k)) + nv(code%c2(k))
        d1(k) = 1.0_wp
        d2(k) = 1.0_wp
      case (OP_SUB)
        nv(k) = nv(code%c1(k)) - nv(code%c2(k))
        d1(k) = 1.0_wp
        d2(k) = -1.0_wp
      case (OP_MUL)
        nv(k) = nv(code%c1(k))*nv(code%c2(k))
        d1(k) = nv(code%c2(k))
        d2(k) = nv(code%c1(k))
      case (OP_FUN)
        if (code%c2(k) > 0) then
          call fun2(code%arg(k), nv(code%c1(k)), nv(code%c2(k)), nv(k), d1(k), d2(k))
        else
          call fun1(code%arg(k), nv(code%c1(k)), nv(k), d1(k))
        end if
      case default
        call binary(code%op(k), nv(code%c1(k)), nv(code%c2(k)), nv(k), d1(k), d2(k))
      end select
    end do
    val = nv(n)
    g = 0.0_wp
    adj(1:n) = 0.0_wp
    adj(n) = 1.0_wp
    do k = n, 1, -1
      if (adj(k) == 0.0_wp) cycle
      select case (code%op(k))
      case (OP_NUM)
      case (OP_VAR)
        g(code%arg(k)) = g(code%arg(k)) + adj(k)
      case default
        adj(code%c1(k)) = adj(code%c1(k)) + adj(k)*d1(k)
        if (code%c2(k) > 0) adj(code%c2(k)) = adj(code%c2(k)) + adj(k)*d2(k)
      end select
    end do
  end subroutine code_gradient

  !> c = a op b and the partials dc/da, dc/db.
  pure subroutine binary(op, a, b, c, da, db)
    integer, intent(in) :: op
    real(wp), intent(in) :: a, b
    real(wp), intent(out) :: c, da, db
    select case (op)
    case (OP_ADD)
      c = a + b
      da = 1.0_wp
      db = 1.0_wp
    case (OP_SUB)
      c = a - b
      da = 1.0_wp
      db = -1.0_wp
    case (OP_MUL)
      c = a*b
      da = b
      db = a
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
