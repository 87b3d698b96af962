!> Table-lookup coefficients: a table over one to three flight-condition
!> variables (alpha, beta, Mach, altitude, dynamic pressure, a configuration
!> flag: any state, input, parameter or definition of the model), given by
!> its breakpoints, its values the model's parameters, interpolated
!> linearly between the breakpoints (multilinear in two or three variables)
!> and held at the end values beyond them (as JSBSim's tables are).
!>
!> A table is a line of an equations model's text (mlid_equations), so
!> that the equations kind and the kinds written as equations (the
!> six-degree-of-freedom aircraft, whose coefficients are its definitions)
!> all have tables in one place:
!>
!>   t NAME(v1[, v2[, v3]]) = b1 b1 ...[; b2 b2 ...[; b3 b3 ...]]
!>
!> NAME is then a definition, the table at (v1, v2, v3).  Its values are
!> parameters of p, in the place of the line among the p lines, named
!> NAME[i], NAME[i,j], NAME[i,j,k] (the value at breakpoints b1(i), b2(j),
!> b3(k); i runs fastest).  The lookup is built from the expression
!> graph's own operations (mlid_expr_diff): sum_ijk p_ijk w1_i(v1) w2_j(v2)
!> w3_k(v3), each w the hat function of a breakpoint, made of clamped
!> ramps r_i = (min(b_i+1, max(v, b_i)) - b_i)/(b_i+1 - b_i).  So the
!> sensitivities are exact with nothing new to differentiate: d/dp_ijk is
!> the interpolation weight, d/dv the slope of the cell, the cell to the
!> right at a breakpoint (a configuration flag on a breakpoint is in the
!> cell it starts), zero beyond the ends.
module mlid_tables
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: itoa, number_text
  use mlid_expr, only: is_name, OP_NUM, OP_VAR, OP_ADD, OP_SUB, OP_MUL, OP_DIV, OP_FUN, F_MIN, &
                       F_MAX
  use mlid_expr_diff, only: graph_t, graph_node
  implicit none
  private
  public :: table_t, table_read, table_graph, table_size, table_value_name, table_value_text, &
            table_smoothness, TABLE_MAXDIM

  integer, parameter :: TABLE_MAXDIM = 3, NAMELEN = 32

  !> A table: its name, variables, breakpoints bp(1:nb(d), d) of each.
  type :: table_t
    character(len=NAMELEN) :: name = ''
    integer :: ndim = 0
    character(len=NAMELEN) :: var(TABLE_MAXDIM) = ''
    integer :: nb(TABLE_MAXDIM) = 1
    real(wp), allocatable :: bp(:, :)
  end type table_t

contains

  !> The table of a line's text after its kind letter:
  !> 'NAME(v1, v2) = b b b; b b'.  Status and a message naming the problem.
  subroutine table_read(text, tab, status, msg)
    character(len=*), intent(in) :: text
    type(table_t), intent(out) :: tab
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: op, cl, eq, k, a, b
    character(len=:), allocatable :: s, rest

    status = MLID_ERR_INPUT
    s = trim(adjustl(text))
    op = index(s, '(')
    cl = index(s, ')')
    eq = index(s, '=')
    if (op < 2 .or. cl < op .or. eq < cl) then
      msg = 'table '''//s//''' is not of the form NAME(v1, v2) = b b ...; b b ...'
      return
    end if
    tab%name = adjustl(s(1:op - 1))
    if (.not. is_name(trim(tab%name)) .or. len_trim(s(1:op - 1)) > NAMELEN - 10) then
      msg = 'table name '''//trim(adjustl(s(1:op - 1)))//''' is not a name of at most '// &
            itoa(NAMELEN - 10)//' characters'
      return
    end if
    call split_list(s(op + 1:cl - 1), ', ', tab%var, tab%ndim, status, msg)
    if (status == MLID_OK .and. tab%ndim == 0) msg = 'no variables'
    if (status == MLID_OK .and. tab%ndim > 0 .and. .not. all([(is_name(trim(tab%var(k))), &
        k=1, tab%ndim)])) msg = 'the variables '''//s(op + 1:cl - 1)//''' are not names'
    if (len_trim(msg) > 0 .or. status /= MLID_OK) then
      status = MLID_ERR_INPUT
      msg = 'table '//trim(tab%name)//': '//trim(msg)//' (one to three names)'
      return
    end if
    rest = s(eq + 1:)
    allocate (tab%bp(0, tab%ndim))
    do k = 1, tab%ndim
      a = 1
      b = index(rest, ';')
      if (b == 0) b = len(rest) + 1
      if (k < tab%ndim .and. b > len(rest)) then
        msg = 'table '//trim(tab%name)//': '//itoa(tab%ndim)//' variables, fewer lists of '// &
              'breakpoints (one for each, separated by '';'')'
        status = MLID_ERR_INPUT
        return
      end if
      call breakpoints(tab, k, rest(a:b - 1), status, msg)
      if (status /= MLID_OK) return
      rest = rest(min(b + 1, len(rest) + 1):)
    end do
    if (len_trim(rest) > 0) then
      status = MLID_ERR_INPUT
      msg = 'table '//trim(tab%name)//': more lists of breakpoints than variables'
    end if
  end subroutine table_read

  !> Breakpoints of variable k from a list of numbers: at least two, finite,
  !> increasing.
  subroutine breakpoints(tab, k, text, status, msg)
    type(table_t), intent(inout) :: tab
    integer, intent(in) :: k
    character(len=*), intent(in) :: text
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=64) :: words(200)
    real(wp) :: v(200)
    real(wp), allocatable :: grown(:, :)
    integer :: n, j, ios

    call split_list(text, ', ', words, n, status, msg)
    do j = 1, n
      if (status /= MLID_OK) exit
      read (words(j), *, iostat=ios) v(j)
      if (ios /= 0 .or. v(j) /= v(j) .or. abs(v(j)) > huge(1.0_wp)) then
        status = MLID_ERR_INPUT
        msg = '''' //trim(words(j))//''' is not a number'
      end if
    end do
    if (status == MLID_OK .and. n < 2) then
      status = MLID_ERR_INPUT
      msg = 'at least two breakpoints are needed'
    end if
    if (status == MLID_OK) then
      if (any(v(2:n) <= v(1:n - 1))) then
        status = MLID_ERR_INPUT
        msg = 'the breakpoints must increase'
      end if
    end if
    if (status /= MLID_OK) then
      msg = 'table '//trim(tab%name)//', breakpoints of '//trim(tab%var(k))//': '//trim(msg)
      return
    end if
    allocate (grown(max(size(tab%bp, 1), n), tab%ndim))
    grown = 0.0_wp
    grown(1:size(tab%bp, 1), 1:k - 1) = tab%bp(:, 1:k - 1)
    grown(1:n, k) = v(1:n)
    call move_alloc(grown, tab%bp)
    tab%nb(k) = n
  end subroutine breakpoints

  !> The words of text between any of the separators seps (empty ones
  !> skipped); at most size(words).
  subroutine split_list(text, seps, words, n, status, msg)
    character(len=*), intent(in) :: text, seps
    character(len=*), intent(out) :: words(:)
    integer, intent(out) :: n, status
    character(len=*), intent(out) :: msg
    integer :: a, b
    n = 0
    status = MLID_OK
    msg = ''
    a = 1
    do while (a <= len(text))
      if (scan(text(a:a), seps) > 0) then
        a = a + 1
        cycle
      end if
      b = a
      do while (b < len(text))
        if (scan(text(b + 1:b + 1), seps) > 0) exit
        b = b + 1
      end do
      n = n + 1
      if (n > size(words) .or. b - a + 1 > len(words)) then
        status = MLID_ERR_INPUT
        msg = 'more than '//itoa(size(words))//' entries, or one too long'
        return
      end if
      words(n) = text(a:b)
      a = b + 1
    end do
  end subroutine split_list

  !> How many values the table has.
  pure integer function table_size(tab)
    type(table_t), intent(in) :: tab
    table_size = product(tab%nb(1:tab%ndim))
  end function table_size

  !> The indices (i, j, k) of value m (1-based, i fastest).
  pure function indices(tab, m) result(ijk)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: m
    integer :: ijk(TABLE_MAXDIM), d, r
    ijk = 1
    r = m - 1
    do d = 1, tab%ndim
      ijk(d) = mod(r, tab%nb(d)) + 1
      r = r/tab%nb(d)
    end do
  end function indices

  !> Value m's parameter name: NAME[i], NAME[i,j] or NAME[i,j,k].
  function table_value_name(tab, m) result(name)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: m
    character(len=NAMELEN) :: name
    integer :: ijk(TABLE_MAXDIM), d
    character(len=:), allocatable :: s
    ijk = indices(tab, m)
    s = trim(tab%name)//'['
    do d = 1, tab%ndim
      s = s//itoa(ijk(d))//trim(merge(',', ']', d < tab%ndim))
    end do
    name = s
  end function table_value_name

  !> Value m said with where it acts: 'CL_tab[3] (alpha = 0.2; weighted
  !> where 0.1 < alpha < 0.3)': the region where its weight is not zero.
  function table_value_text(tab, m) result(text)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: m
    character(len=:), allocatable :: text, at, span
    integer :: ijk(TABLE_MAXDIM), d, i, n
    ijk = indices(tab, m)
    at = ''
    span = ''
    do d = 1, tab%ndim
      i = ijk(d)
      n = tab%nb(d)
      if (d > 1) at = at//', '
      if (d > 1) span = span//', '
      at = at//trim(tab%var(d))//' = '//number_text(tab%bp(i, d))
      if (i > 1) span = span//number_text(tab%bp(i - 1, d))//' < '
      span = span//trim(tab%var(d))
      if (i < n) span = span//' < '//number_text(tab%bp(i + 1, d))
    end do
    text = trim(table_value_name(tab, m))//' ('//at//'; weighted where '//span//')'
  end function table_value_text

  !> The table's lookup as nodes of g: root the node of its value at the
  !> variables' nodes vnode(1:ndim), its values the variables p0 + 1 ..
  !> p0 + table_size of the graph (the model's parameters).
  subroutine table_graph(g, tab, vnode, p0, root, status, msg)
    type(graph_t), intent(inout) :: g
    type(table_t), intent(in) :: tab
    integer, intent(in) :: vnode(:), p0
    integer, intent(out) :: root, status
    character(len=*), intent(out) :: msg
    integer :: hat(size(tab%bp, 1), TABLE_MAXDIM), ijk(TABLE_MAXDIM), d, m, w, w2, pv, term, sum

    root = 0
    status = MLID_OK
    msg = ''
    do d = 1, tab%ndim
      call hats(g, tab%bp(1:tab%nb(d), d), vnode(d), hat(1:tab%nb(d), d), status, msg)
    end do
    sum = 0
    do m = 1, table_size(tab)
      ijk = indices(tab, m)
      w = hat(ijk(1), 1)
      do d = 2, tab%ndim
        call add(g, OP_MUL, 0, 0.0_wp, w, hat(ijk(d), d), w2, status, msg)
        w = w2
      end do
      call add(g, OP_VAR, p0 + m, 0.0_wp, 0, 0, pv, status, msg)
      call add(g, OP_MUL, 0, 0.0_wp, pv, w, term, status, msg)
      if (m == 1) then
        root = term
      else
        call add(g, OP_ADD, 0, 0.0_wp, root, term, sum, status, msg)
        root = sum
      end if
    end do
  end subroutine table_graph

  !> The hat functions of breakpoints bp at node v: hat(i) is 1 at bp(i),
  !> 0 at the others, linear between, held beyond the ends.  From the
  !> clamped ramps r_i = (min(bp(i+1), max(v, bp(i))) - bp(i))/(bp(i+1) -
  !> bp(i)): hat(1) = 1 - r_1, hat(i) = r_i-1 - r_i, hat(n) = r_n-1.  The
  !> operands' order makes the slope at a breakpoint the right cell's
  !> (max(v, b): d/dv = 1 at v = b; min(b, v): d/dv = 0 at v = b).
  subroutine hats(g, bp, v, hat, status, msg)
    type(graph_t), intent(inout) :: g
    real(wp), intent(in) :: bp(:)
    integer, intent(in) :: v
    integer, intent(out) :: hat(:)
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    integer :: r(size(bp) - 1), i, lo, hi, up, low, shifted, h, one, n

    hat = 0
    n = size(bp)
    do i = 1, n - 1
      call add(g, OP_NUM, 0, bp(i), 0, 0, lo, status, msg)
      call add(g, OP_NUM, 0, bp(i + 1), 0, 0, hi, status, msg)
      call add(g, OP_FUN, F_MAX, 0.0_wp, v, lo, up, status, msg)
      call add(g, OP_FUN, F_MIN, 0.0_wp, hi, up, low, status, msg)
      call add(g, OP_SUB, 0, 0.0_wp, low, lo, shifted, status, msg)
      call add(g, OP_NUM, 0, bp(i + 1) - bp(i), 0, 0, h, status, msg)
      call add(g, OP_DIV, 0, 0.0_wp, shifted, h, r(i), status, msg)
    end do
    call add(g, OP_NUM, 0, 1.0_wp, 0, 0, one, status, msg)
    call add(g, OP_SUB, 0, 0.0_wp, one, r(1), hat(1), status, msg)
    do i = 2, n - 1
      call add(g, OP_SUB, 0, 0.0_wp, r(i - 1), r(i), hat(i), status, msg)
    end do
    hat(n) = r(n - 1)
  end subroutine hats

  !> k: the node op(arg, num) of a, b (graph_node), unless an earlier one
  !> failed (status kept, k = 0).
  subroutine add(g, op, arg, num, a, b, k, status, msg)
    type(graph_t), intent(inout) :: g
    integer, intent(in) :: op, arg, a, b
    real(wp), intent(in) :: num
    integer, intent(out) :: k
    integer, intent(inout) :: status
    character(len=*), intent(inout) :: msg
    k = 0
    if (status /= MLID_OK) return
    call graph_node(g, op, arg, num, a, b, k, status, msg)
  end subroutine add

  !> The smoothness prior's weight over the table's values, added into
  !> w(p0 + 1 .., p0 + 1 ..): lambda times D'D, D the second differences
  !> along each variable between neighbours, as the change of slope times
  !> the mean spacing, ((p_i+1 - p_i)/h_i - (p_i - p_i-1)/h_i-1) (h_i-1 +
  !> h_i)/2 (p_i-1 - 2 p_i + p_i+1 on even breakpoints; zero for a table
  !> linear in that variable on any).  The prior's cost is then 1/2 lambda
  !> sum of their squares: lambda = 1/sigma^2, sigma the a priori spread of
  !> one second difference.
  pure subroutine table_smoothness(tab, p0, lambda, w)
    type(table_t), intent(in) :: tab
    integer, intent(in) :: p0
    real(wp), intent(in) :: lambda
    real(wp), intent(inout) :: w(:, :)
    integer :: m, d, ijk(TABLE_MAXDIM), stride, c(3), a, b
    real(wp) :: h1, h2, row(3)

    do d = 1, tab%ndim
      stride = product(tab%nb(1:d - 1))
      do m = 1, table_size(tab)
        ijk = indices(tab, m)
        if (ijk(d) == 1 .or. ijk(d) == tab%nb(d)) cycle
        h1 = tab%bp(ijk(d), d) - tab%bp(ijk(d) - 1, d)
        h2 = tab%bp(ijk(d) + 1, d) - tab%bp(ijk(d), d)
        row = [1.0_wp/h1, -(1.0_wp/h1 + 1.0_wp/h2), 1.0_wp/h2]*0.5_wp*(h1 + h2)
        c = p0 + [m - stride, m, m + stride]
        do a = 1, 3
          do b = 1, 3
            w(c(a), c(b)) = w(c(a), c(b)) + lambda*row(a)*row(b)
          end do
        end do
      end do
    end do
  end subroutine table_smoothness

end module mlid_tables
