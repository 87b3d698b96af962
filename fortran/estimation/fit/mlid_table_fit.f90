!> The two-step route from local fits to tables over the flight envelope:
!> the table values v fitted to the manoeuvres' local estimates theta
!> (each manoeuvre's estimates of the derivatives the tables model) with
!> their covariance C by weighted least squares,
!>
!>   min_v (theta - A v)' C^-1 (theta - A v),
!>
!> A the tables' interpolation weights at each manoeuvre's flight
!> condition (mlid_tables' own lookup, differentiated: one place for the
!> interpolation); then the chi-square test of each manoeuvre's estimates
!> against the tables.  With M = A' C^-1 A: v = M^-1 A' C^-1 theta, Cov(v)
!> = M^-1; the residuals r = theta - A v have the covariance C - A M^-1 A'
!> (r is C's part orthogonal, in C^-1, to A's columns), so manoeuvre i's
!> chi2_i = r_i' S_i^+ r_i, S_i = C_ii - A_i M^-1 A_i', is chi-square with
!> rank(S_i) degrees of freedom when the tables hold.  (C_ii in place of S_i
!> would understate every chi2_i and hide most of a manoeuvre that alone
!> decides a value: its residual there is zero whatever its error.)  The
!> whole campaign's r' C^-1 r is chi-square with K - rank(M) degrees of
!> freedom.  A table value whose weights are zero at every manoeuvre is
!> not reached (no value, NaN); values reached only in a fixed combination
!> are refused by name.  The same tests against values fitted elsewhere
!> (the one-step global fit of the manoeuvres' records): table_test.
module mlid_table_fit
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_SINGULAR, MLID_ERR_INTERNAL, &
                        MLID_ERR_MEMORY
  use mlid_text, only: itoa, es_text
  use mlid_expr, only: OP_VAR
  use mlid_expr_diff, only: graph_t, program_t, graph_node, program_of, program_forward, &
                            program_jacobian, MAXNODE, MAXVAR
  use mlid_tables, only: table_t, table_read, table_graph, table_size
  use mlid_linalg, only: chol_inverse, info_inverse, sym_eig
  use mlid_chi2, only: chi2_sf, chi2_limit
  implicit none
  private
  public :: table_fit_t, tables_of_text, table_design, table_fit, table_test, table_count

  !> Below this, an eigenvalue of a manoeuvre's residual covariance (in
  !> units of its own covariance, so between 0 and 1) is a direction the
  !> manoeuvre alone decides: no degree of freedom.
  real(wp), parameter :: DOF_TOL = 1.0e-9_wp
  !> Below minus this, an eigenvalue of it is no rounding: S_i is not a
  !> covariance (an error, not a direction to drop).
  real(wp), parameter :: NEG_TOL = 1.0e-8_wp
  !> Below this times the largest, an eigenvalue of the normalised M is a
  !> combination of values no manoeuvre separates.
  real(wp), parameter :: RCOND = 1.0e-12_wp

  !> The fit: values (NaN where not reached) and their covariance; each
  !> entry's residual; each manoeuvre's chi2, its degrees of freedom,
  !> p-value, the limit at the level and whether it passes it; the
  !> campaign's total.
  type :: table_fit_t
    real(wp), allocatable :: v(:), cov(:, :), resid(:)
    logical, allocatable :: reached(:)
    real(wp), allocatable :: chi2(:), pval(:), limit(:)
    integer, allocatable :: dof(:)
    logical, allocatable :: disagree(:)
    real(wp) :: chi2_total = 0.0_wp, p_total = 1.0_wp, limit_total = 0.0_wp
    integer :: dof_total = 0
  end type table_fit_t

contains

  !> The tables of lines of text 'NAME(v1, v2) = b b; b b' (mlid_tables'
  !> table_read), one a line.
  subroutine tables_of_text(lines, tabs, status, msg)
    character(len=*), intent(in) :: lines(:)
    type(table_t), allocatable, intent(out) :: tabs(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: t, j
    status = MLID_OK
    msg = ''
    allocate (tabs(size(lines)))
    if (size(lines) == 0) then
      status = MLID_ERR_INPUT
      msg = 'table fit: no tables'
      return
    end if
    do t = 1, size(lines)
      call table_read(lines(t), tabs(t), status, msg)
      if (status /= MLID_OK) return
      do j = 1, t - 1
        if (tabs(j)%name == tabs(t)%name) then
          status = MLID_ERR_INPUT
          msg = 'table fit: two tables named '//trim(tabs(t)%name)
          return
        end if
      end do
    end do
  end subroutine tables_of_text

  !> How many values the tables have together.
  pure integer function table_count(tabs)
    type(table_t), intent(in) :: tabs(:)
    integer :: t
    table_count = 0
    do t = 1, size(tabs)
      table_count = table_count + table_size(tabs(t))
    end do
  end function table_count

  !> The weights a(K, nv) of the entries: entry e, an estimate of table
  !> etab(e)'s quantity at manoeuvre eman(e), has the weights of that
  !> table at the manoeuvre's condition cond(:, eman(e)) (its values over
  !> the variables vars) in the table's columns, zero elsewhere.  labels
  !> name the manoeuvres in messages.
  subroutine table_design(tabs, vars, cond, labels, etab, eman, a, status, msg)
    type(table_t), intent(in) :: tabs(:)
    character(len=*), intent(in) :: vars(:), labels(:)
    real(wp), intent(in) :: cond(:, :)
    integer, intent(in) :: etab(:), eman(:)
    real(wp), allocatable, intent(out) :: a(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: first(size(tabs) + 1), e, t, d, k, ierr
    real(wp) :: x(3)

    status = MLID_ERR_INPUT
    first(1) = 0
    do t = 1, size(tabs)
      first(t + 1) = first(t) + table_size(tabs(t))
    end do
    if (any(etab < 1 .or. etab > size(tabs)) .or. any(eman < 1 .or. eman > size(cond, 2))) then
      msg = 'table fit: an entry names no table (1 to '//itoa(size(tabs))// &
            ') or no manoeuvre (1 to '//itoa(size(cond, 2))//')'
      return
    end if
    allocate (a(size(etab), first(size(tabs) + 1)), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'table fit: no memory for the weights of '//itoa(size(etab))//' entries'
      return
    end if
    a = 0.0_wp
    do e = 1, size(etab)
      t = etab(e)
      do d = 1, tabs(t)%ndim
        k = findloc(vars, tabs(t)%var(d), 1)
        if (k == 0) then
          msg = 'table fit: table '//trim(tabs(t)%name)//'''s variable '// &
                trim(tabs(t)%var(d))//' is none of the conditions given'
          return
        end if
        x(d) = cond(k, eman(e))
        if (.not. ieee_is_finite(x(d))) then
          msg = 'table fit: manoeuvre '''//trim(labels(eman(e)))//''' has no value of '// &
                trim(tabs(t)%var(d))//' (a variable of table '//trim(tabs(t)%name)//')'
          return
        end if
      end do
      call table_weights(tabs(t), x(1:tabs(t)%ndim), a(e, first(t) + 1:first(t + 1)), status, &
                         msg)
      if (status /= MLID_OK) return
    end do
  end subroutine table_design

  !> The weights w of tab's values at the point x: the gradient of its
  !> lookup (table_graph, the model's own) with respect to the values,
  !> exact: the lookup is linear in them.
  subroutine table_weights(tab, x, w, status, msg)
    type(table_t), intent(in) :: tab
    real(wp), intent(in) :: x(:)
    real(wp), intent(out) :: w(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(graph_t) :: g
    type(program_t) :: prog
    real(wp) :: nv(MAXNODE), d1(MAXNODE), d2(MAXNODE), jx(1, 0), jp(1, size(w)), v(size(x) + &
                size(w))
    integer :: vnode(size(x)), d, m, root

    w = 0.0_wp
    if (size(x) + size(w) > MAXVAR) then
      status = MLID_ERR_INPUT
      msg = 'table fit: table '//trim(tab%name)//' has over '//itoa(MAXVAR - size(x))//' values'
      return
    end if
    do d = 1, size(x)
      call graph_node(g, OP_VAR, d, 0.0_wp, 0, 0, vnode(d), status, msg)
      if (status /= MLID_OK) return
    end do
    call table_graph(g, tab, vnode, size(x), root, status, msg)
    if (status /= MLID_OK) return
    prog = program_of(g, [root], size(v))
    v = 0.0_wp
    v(1:size(x)) = x
    call program_forward(prog, v, nv, d1, d2)
    call program_jacobian(prog, d1, d2, 0, jx, size(x), [(m, m=1, size(w))], jp)
    w = jp(1, :)
  end subroutine table_weights

  !> The weighted least-squares fit of the values to theta(K) with
  !> covariance c(K, K) through the weights a(K, nv), and the chi-square
  !> test of each manoeuvre's entries (eman, 1 .. nman; labels name them)
  !> at the level (the probability of naming a manoeuvre that agrees).
  !> names: each value's name, for a message.
  subroutine table_fit(a, theta, c, eman, labels, names, level, res, status, msg)
    real(wp), intent(in) :: a(:, :), theta(:), c(:, :), level
    integer, intent(in) :: eman(:)
    character(len=*), intent(in) :: labels(:), names(:)
    type(table_fit_t), intent(out) :: res
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: cinv(:, :), ar(:, :), m(:, :), p(:, :), w(:), vec(:, :), ca(:, :)
    integer, allocatable :: idx(:)
    real(wp) :: logdet, nan
    integer :: nv, info, ndrop, bad, i

    call check_inputs(theta, c, eman, size(labels), level, labels, status, msg)
    if (status /= MLID_OK) return
    nv = size(a, 2)
    nan = ieee_value(0.0_wp, ieee_quiet_nan)
    res%reached = [(any(a(:, i) /= 0.0_wp), i=1, nv)]
    idx = pack([(i, i=1, nv)], res%reached)
    allocate (cinv(size(c, 1), size(c, 2)))
    call chol_inverse(c, cinv, logdet, info)
    if (info /= 0) then
      status = MLID_ERR_SINGULAR
      msg = 'table fit: the local estimates'' covariance is not positive definite'
      return
    end if
    ar = a(:, idx)
    ca = matmul(cinv, ar)
    m = matmul(transpose(ar), ca)
    allocate (p(size(idx), size(idx)), w(size(idx)), vec(size(idx), size(idx)))
    call info_inverse(m, RCOND, p, w, ndrop, bad, status, msg, vec=vec)
    if (status /= MLID_OK) return
    if (ndrop > 0) then
      status = MLID_ERR_SINGULAR
      msg = 'table fit: the values '//combination(names(idx), vec(:, 1))// &
            ' are reached only in a fixed combination (no manoeuvre separates them): add '// &
            'manoeuvres between their breakpoints, or fit fewer values'
      return
    end if
    allocate (res%v(nv), res%cov(nv, nv))
    res%v = nan
    res%cov = nan
    res%v(idx) = matmul(p, matmul(transpose(ca), theta))
    res%cov(idx, idx) = p
    call tests_of(ar, theta, c, cinv, idx, eman, size(labels), level, res, status, msg)
  end subroutine table_fit

  !> table_fit's chi-square tests of the local estimates theta (covariance
  !> c) against values v fitted elsewhere: the one-step global fit of the
  !> same manoeuvres' records.  Only v is taken from there: S_i is built
  !> from P = (A' C^-1 A)^-1 of the local covariances, as in table_fit
  !> (positive semi-definite, exactly singular where a manoeuvre alone
  !> decides a value), not from the global fit's own Cov(v): its difference
  !> from P is noise, which would make S_i's small eigenvalues, and so the
  !> degrees of freedom, random.  The test holds (Hausman: the global v is
  !> then, to first order, the efficient estimate, and theta_i - A_i v has
  !> the covariance C_ii - A_i P A_i') when the local fits are of the same
  !> records, each local model contains the global one at its manoeuvre's
  !> condition, the noise is the same in every manoeuvre (the global fit's
  !> one R-hat), and the global fit has no prior (a prior moves v off the
  !> local estimates' weighted mean).  v must be finite at every value a
  !> manoeuvre reaches; names name the values in a message.
  subroutine table_test(a, theta, c, eman, labels, names, v, level, res, status, msg)
    real(wp), intent(in) :: a(:, :), theta(:), c(:, :), v(:), level
    integer, intent(in) :: eman(:)
    character(len=*), intent(in) :: labels(:), names(:)
    type(table_fit_t), intent(out) :: res
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: cinv(:, :), ar(:, :), m(:, :), p(:, :), w(:), vec(:, :)
    integer, allocatable :: idx(:)
    real(wp) :: logdet
    integer :: nv, info, i, ndrop, bad

    call check_inputs(theta, c, eman, size(labels), level, labels, status, msg)
    if (status /= MLID_OK) return
    nv = size(a, 2)
    status = MLID_ERR_INPUT
    if (size(v) /= nv) then
      msg = 'table test: the values must be '//itoa(nv)
      return
    end if
    res%reached = [(any(a(:, i) /= 0.0_wp), i=1, nv)]
    idx = pack([(i, i=1, nv)], res%reached)
    if (.not. all(ieee_is_finite(v(idx)))) then
      msg = 'table test: a value a manoeuvre reaches is not finite'
      return
    end if
    allocate (cinv(size(c, 1), size(c, 2)))
    call chol_inverse(c, cinv, logdet, info)
    if (info /= 0) then
      status = MLID_ERR_SINGULAR
      msg = 'table test: the local estimates'' covariance is not positive definite'
      return
    end if
    ar = a(:, idx)
    m = matmul(transpose(ar), matmul(cinv, ar))
    allocate (p(size(idx), size(idx)), w(size(idx)), vec(size(idx), size(idx)))
    call info_inverse(m, RCOND, p, w, ndrop, bad, status, msg, vec=vec)
    if (status /= MLID_OK) return
    if (ndrop > 0) then
      status = MLID_ERR_SINGULAR
      msg = 'table test: the local estimates reach the values '//combination(names(idx), &
            vec(:, 1))//' only in a fixed combination: nothing to test them against'
      return
    end if
    allocate (res%cov(nv, nv))
    res%cov = ieee_value(0.0_wp, ieee_quiet_nan)
    res%cov(idx, idx) = p
    res%v = v
    call tests_of(ar, theta, c, cinv, idx, eman, size(labels), level, res, status, msg)
  end subroutine table_test

  !> The residuals theta - A v at res%v, the campaign's total chi2 and each
  !> manoeuvre's test (ar: A's columns of the reached values idx).
  subroutine tests_of(ar, theta, c, cinv, idx, eman, nman, level, res, status, msg)
    real(wp), intent(in) :: ar(:, :), theta(:), c(:, :), cinv(:, :), level
    integer, intent(in) :: idx(:), eman(:), nman
    type(table_fit_t), intent(inout) :: res
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    res%resid = theta - matmul(ar, res%v(idx))
    res%chi2_total = dot_product(res%resid, matmul(cinv, res%resid))
    res%dof_total = size(theta) - size(idx)
    call verdict(res%chi2_total, res%dof_total, level, res%p_total, res%limit_total)
    call manoeuvre_tests(ar, c, res%cov(idx, idx), res%resid, eman, nman, level, res, status, &
                         msg)
  end subroutine tests_of

  !> Sizes, finite numbers, the level: one line naming what is wrong.
  subroutine check_inputs(theta, c, eman, nman, level, labels, status, msg)
    real(wp), intent(in) :: theta(:), c(:, :), level
    integer, intent(in) :: eman(:), nman
    character(len=*), intent(in) :: labels(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: i, e
    status = MLID_ERR_INPUT
    msg = ''
    if (.not. (level > 0.0_wp .and. level < 1.0_wp)) then
      msg = 'table fit: the level must be between 0 and 1'
    else if (size(theta) == 0) then
      msg = 'table fit: no local estimates'
    else if (size(c, 1) /= size(theta) .or. size(c, 2) /= size(theta)) then
      msg = 'table fit: the covariance must be '//itoa(size(theta))//' x '//itoa(size(theta))
    end if
    if (len_trim(msg) > 0) return
    do i = 1, nman
      if (.not. any(eman == i)) then
        msg = 'table fit: manoeuvre '''//trim(labels(i))//''' has no estimate of a tabled '// &
              'quantity'
        return
      end if
    end do
    do e = 1, size(theta)
      if (.not. (ieee_is_finite(theta(e)) .and. all(ieee_is_finite(c(:, e))))) then
        msg = 'table fit: manoeuvre '''//trim(labels(eman(e)))//'''s estimate '//itoa(e)// &
              ' or its covariance is not finite'
        return
      end if
      if (c(e, e) <= 0.0_wp) then
        msg = 'table fit: manoeuvre '''//trim(labels(eman(e)))//'''s estimate '//itoa(e)// &
              ' has no variance (a fixed parameter is no estimate)'
        return
      end if
    end do
    if (any(abs(c - transpose(c)) > 1.0e-10_wp*maxval(abs(c)))) then
      msg = 'table fit: the covariance is not symmetric'
      return
    end if
    status = MLID_OK
  end subroutine check_inputs

  !> The names with a weight over a third of the largest in vector u.
  function combination(names, u) result(text)
    character(len=*), intent(in) :: names(:)
    real(wp), intent(in) :: u(:)
    character(len=:), allocatable :: text
    integer :: k
    text = ''
    do k = 1, size(names)
      if (abs(u(k)) < maxval(abs(u))/3.0_wp) cycle
      if (len(text) > 0) text = text//', '
      text = text//trim(names(k))
    end do
  end function combination

  !> The p-value and the limit of chi2 with dof degrees of freedom (none:
  !> p = 1, limit 0: nothing to test).
  pure subroutine verdict(chi2, dof, level, pval, limit)
    real(wp), intent(in) :: chi2, level
    integer, intent(in) :: dof
    real(wp), intent(out) :: pval, limit
    pval = 1.0_wp
    limit = 0.0_wp
    if (dof < 1) return
    pval = chi2_sf(chi2, dof)
    limit = chi2_limit(level, dof)
  end subroutine verdict

  !> Each manoeuvre's chi2_i = r_i' S_i^+ r_i, S_i = C_ii - A_i P A_i', in
  !> the units of C_ii: with C_ii = U diag(c) U' and T = diag(c)^-1/2 U',
  !> T S_i T' = V diag(s) V' (s in [0, 1]: 1 where the tables take nothing
  !> from the manoeuvre, 0 where it alone decides them), z = V' T r_i,
  !> chi2_i = sum z_k^2 / s_k over s_k > DOF_TOL, those its degrees of
  !> freedom; an s_k below -NEG_TOL is an error (S_i no covariance).
  subroutine manoeuvre_tests(ar, c, p, r, eman, nman, level, res, status, msg)
    real(wp), intent(in) :: ar(:, :), c(:, :), p(:, :), r(:), level
    integer, intent(in) :: eman(:), nman
    type(table_fit_t), intent(inout) :: res
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: cw(:), u(:, :), tm(:, :), s(:, :), sw(:), v(:, :), z(:), ai(:, :)
    integer, allocatable :: e(:)
    integer :: i, k, info, n

    status = MLID_OK
    msg = ''
    allocate (res%chi2(nman), res%pval(nman), res%limit(nman), res%dof(nman), &
              res%disagree(nman))
    do i = 1, nman
      e = pack([(k, k=1, size(eman))], eman == i)
      n = size(e)
      allocate (cw(n), u(n, n), sw(n), v(n, n))
      call sym_eig(c(e, e), cw, u, info)
      if (info == 0 .and. cw(1) <= 0.0_wp) info = -1
      if (info /= 0) exit
      tm = transpose(u)
      do k = 1, n
        tm(k, :) = tm(k, :)/sqrt(cw(k))
      end do
      ai = ar(e, :)
      s = c(e, e) - matmul(ai, matmul(p, transpose(ai)))
      s = matmul(tm, matmul(s, transpose(tm)))
      call sym_eig(0.5_wp*(s + transpose(s)), sw, v, info)
      if (info /= 0) exit
      if (sw(1) < -NEG_TOL) then
        status = MLID_ERR_INTERNAL
        msg = 'table fit: manoeuvre '//itoa(i)//'''s residual covariance has the eigenvalue '// &
              es_text(sw(1), 10, 3)//' (of its own 1): not a covariance'
        return
      end if
      z = matmul(transpose(v), matmul(tm, r(e)))
      res%dof(i) = count(sw > DOF_TOL)
      res%chi2(i) = sum(z**2/max(sw, DOF_TOL), mask=sw > DOF_TOL)
      call verdict(res%chi2(i), res%dof(i), level, res%pval(i), res%limit(i))
      res%disagree(i) = res%dof(i) > 0 .and. res%pval(i) < level
      deallocate (cw, u, sw, v)
    end do
    if (info /= 0) then
      status = MLID_ERR_INTERNAL
      msg = 'table fit: the eigen-decomposition of manoeuvre '//itoa(i)//'''s covariance failed'
    end if
  end subroutine manoeuvre_tests

end module mlid_table_fit
