!> The flat interface's two-step table fit (mlid_table_fit): tables fitted
!> to the local estimates of a campaign's manoeuvres, and the consistency
!> test of each manoeuvre.  Both routines take the handle alone, their
!> inputs the handle's given values (mlid_api_values).  Conventions:
!> mlid_api_deck's comment.
module mlid_api_table_fit
  use, intrinsic :: iso_c_binding, only: c_int, c_int64_t
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_handles, only: session_t, call_session
  use mlid_named, only: named_t
  use mlid_text, only: name_lines, join_lines, itoa
  use mlid_tables, only: table_t, table_size, table_value_name, table_value_text
  use mlid_table_fit, only: table_fit_t, tables_of_text, table_design, table_fit, table_test, &
                            table_count
  implicit none
  private
  public :: mlid_table_fit, mlid_table_test, mlid_table_weights

  integer, parameter :: LINELEN = 4096, NAMELEN = 64

contains

  !> The tables of handle h's given values fitted to the local estimates.
  !> Given: tables (text, one table a line: 'NAME(v1, v2) = b b; b b'),
  !> variables (text, a name a line), conditions (nvar, nman: each
  !> manoeuvre's values of the variables, NaN where it has none), labels
  !> (text, a manoeuvre's name a line), entry_table and entry_manoeuvre
  !> (K: which table's quantity each estimate is, and of which manoeuvre),
  !> theta (K), covariance (K, K), level (of the chi-square tests).
  !> Results: names and cells (text: each value's name, and where it is
  !> weighted), values, sigma (nv; NaN where not reached), covariance (nv,
  !> nv), reached (nv; 1 or 0), weights (K, nv), residuals (K), chi2, dof,
  !> p_value, limit, disagree (nman), chi2_total, dof_total, p_total,
  !> limit_total.
  subroutine mlid_table_fit(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(table_t), allocatable :: tabs(:)
    character(len=NAMELEN), allocatable :: labels(:), names(:)
    real(wp), allocatable :: a(:, :), theta(:), c(:, :)
    integer, allocatable :: eman(:)
    type(table_fit_t) :: r
    real(wp) :: level
    integer :: st

    call local_estimates(h, s, tabs, labels, eman, a, theta, c, level, st, msg)
    status = st
    if (st /= MLID_OK) return
    call value_texts(tabs, names, s%results)
    call table_fit(a, theta, c, eman, labels, names, level, r, st, msg)
    status = st
    if (st == MLID_OK) call put_fit(r, a, s%results)
  end subroutine mlid_table_fit

  !> The chi-square tests of mlid_table_fit against the given values
  !> 'values' (nv), fitted elsewhere (the one-step global fit): the same
  !> given values besides and the same results (values those given; sigma
  !> and covariance those of the local estimates, table_test's P).
  subroutine mlid_table_test(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(table_t), allocatable :: tabs(:)
    character(len=NAMELEN), allocatable :: labels(:), names(:)
    real(wp), allocatable :: a(:, :), theta(:), c(:, :), v(:)
    integer, allocatable :: eman(:)
    type(table_fit_t) :: r
    real(wp) :: level
    integer :: st

    call local_estimates(h, s, tabs, labels, eman, a, theta, c, level, st, msg)
    if (st == MLID_OK) call s%given%get('values', v, st, msg, [size(a, 2)])
    status = st
    if (st /= MLID_OK) return
    call value_texts(tabs, names, s%results)
    call table_test(a, theta, c, eman, labels, names, v, level, r, st, msg)
    status = st
    if (st == MLID_OK) call put_fit(r, a, s%results)
  end subroutine mlid_table_test

  !> What mlid_table_fit and mlid_table_test both read of handle h: the
  !> session, the tables' design (design_of), the local estimates 'theta',
  !> their 'covariance' and the tests' 'level'.
  subroutine local_estimates(h, s, tabs, labels, eman, a, theta, c, level, st, msg)
    integer(c_int64_t), intent(in) :: h
    type(session_t), pointer, intent(out) :: s
    type(table_t), allocatable, intent(out) :: tabs(:)
    character(len=NAMELEN), allocatable, intent(out) :: labels(:)
    integer, allocatable, intent(out) :: eman(:)
    real(wp), allocatable, intent(out) :: a(:, :), theta(:), c(:, :)
    real(wp), intent(out) :: level
    integer, intent(out) :: st
    character(len=*), intent(out) :: msg
    level = 0.0_wp
    call call_session(h, s, st, msg)
    if (st == MLID_OK) call design_of(s%given, tabs, labels, eman, a, st, msg)
    if (st == MLID_OK) call s%given%get('theta', theta, st, msg, [size(eman)])
    if (st == MLID_OK) call s%given%get('covariance', c, st, msg, [size(eman), size(eman)])
    if (st == MLID_OK) call s%given%get('level', level, st, msg)
  end subroutine local_estimates

  !> A table fit's or test's results by name (mlid_table_fit's list).
  subroutine put_fit(r, a, o)
    type(table_fit_t), intent(in) :: r
    real(wp), intent(in) :: a(:, :)
    type(named_t), intent(inout) :: o
    integer :: k
    call o%put('values', r%v)
    call o%put('sigma', sqrt([(r%cov(k, k), k=1, size(r%v))]))
    call o%put('covariance', r%cov)
    call o%put('reached', merge(1, 0, r%reached))
    call o%put('weights', a)
    call o%put('residuals', r%resid)
    call o%put('chi2', r%chi2)
    call o%put('dof', r%dof)
    call o%put('p_value', r%pval)
    call o%put('limit', r%limit)
    call o%put('disagree', merge(1, 0, r%disagree))
    call o%put('chi2_total', r%chi2_total)
    call o%put('dof_total', r%dof_total)
    call o%put('p_total', r%p_total)
    call o%put('limit_total', r%limit_total)
  end subroutine put_fit

  !> The tables' interpolation weights (mlid_table_fit's weights alone):
  !> the given values tables, variables, conditions, labels, entry_table,
  !> entry_manoeuvre of mlid_table_fit; results weights (K, nv), names and
  !> cells.  A table over a grid of points: each point a "manoeuvre".
  subroutine mlid_table_weights(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(table_t), allocatable :: tabs(:)
    character(len=NAMELEN), allocatable :: labels(:), names(:)
    real(wp), allocatable :: a(:, :)
    integer, allocatable :: eman(:)
    integer :: st

    call call_session(h, s, st, msg)
    if (st == MLID_OK) call design_of(s%given, tabs, labels, eman, a, st, msg)
    status = st
    if (st /= MLID_OK) return
    call value_texts(tabs, names, s%results)
    call s%results%put('weights', a)
  end subroutine mlid_table_weights

  !> The tables, the manoeuvres' labels and entries, and the weights from
  !> the given values g.
  subroutine design_of(g, tabs, labels, eman, a, status, msg)
    type(named_t), intent(in) :: g
    type(table_t), allocatable, intent(out) :: tabs(:)
    character(len=NAMELEN), allocatable, intent(out) :: labels(:)
    integer, allocatable, intent(out) :: eman(:)
    real(wp), allocatable, intent(out) :: a(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=:), allocatable :: text
    character(len=LINELEN), allocatable :: lines(:)
    character(len=NAMELEN), allocatable :: vars(:)
    real(wp), allocatable :: cond(:, :)
    integer, allocatable :: etab(:)

    status = MLID_OK
    call g%get('tables', text, status, msg)
    if (status /= MLID_OK) return
    call name_lines(text, lines)
    call tables_of_text(lines, tabs, status, msg)
    if (status == MLID_OK) call g%get('variables', text, status, msg)
    if (status /= MLID_OK) return
    call name_lines(text, vars)
    call g%get('conditions', cond, status, msg)
    if (status == MLID_OK) call g%get('labels', text, status, msg)
    if (status /= MLID_OK) return
    call name_lines(text, labels)
    call g%get('entry_table', etab, status, msg)
    if (status == MLID_OK) call g%get('entry_manoeuvre', eman, status, msg, [size(etab)])
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (size(cond, 1) /= size(vars) .or. size(cond, 2) /= size(labels)) then
      msg = 'table fit: conditions must be '//itoa(size(vars))//' variables x '// &
            itoa(size(labels))//' manoeuvres'
      return
    end if
    call table_design(tabs, vars, cond, labels, etab, eman, a, status, msg)
  end subroutine design_of

  !> Each value's name and where it is weighted (mlid_tables), into the
  !> results as names and cells; names also returned.
  subroutine value_texts(tabs, names, results)
    type(table_t), intent(in) :: tabs(:)
    character(len=NAMELEN), allocatable, intent(out) :: names(:)
    type(named_t), intent(inout) :: results
    character(len=:), allocatable :: cells
    integer :: t, m, k
    allocate (names(table_count(tabs)))
    cells = ''
    k = 0
    do t = 1, size(tabs)
      do m = 1, table_size(tabs(t))
        k = k + 1
        names(k) = table_value_name(tabs(t), m)
        cells = cells//table_value_text(tabs(t), m)//achar(10)
      end do
    end do
    call results%put('names', join_lines(names))
    call results%put('cells', cells)
  end subroutine value_texts

end module mlid_api_table_fit
