!> Stepwise regression with the partial F-test (Klein and Morelli 2006,
!> sec. 5.4.1; Draper and Smith), on the scaled cross products and their
!> sweep (mlid_regression):
!> - forward: from the forced terms, the candidate of the largest partial F
!>   enters while that F is at least F_in; after each entry every term
!>   whose partial F has fallen below F_out leaves (the smallest first), so
!>   a term that a later one explains goes again;
!> - backward: from all candidates, the term of the smallest partial F
!>   leaves while that F is below F_out.
!> The forced terms (the constant) never leave.  The final estimates are
!> least squares on the chosen terms (regression_finish).
module mlid_stepwise
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_MEMORY
  use mlid_text, only: itoa
  use mlid_regression, only: regression_settings_t, regression_t, regression_check, &
                             cross_products, sweep, f_enter, f_remove, path_start, path_add, &
                             regression_finish, TOL
  implicit none
  private
  public :: stepwise_forward, stepwise_backward

contains

  !> Forward selection with removals (the stepwise procedure) of the
  !> candidates x (N, m) for y, the forced ones always in.
  subroutine stepwise_forward(x, y, forced, s, r, status, msg)
    real(wp), intent(in) :: x(:, :), y(:)
    logical, intent(in) :: forced(:)
    type(regression_settings_t), intent(in) :: s
    type(regression_t), intent(out) :: r
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: a(:, :)
    logical :: in(size(forced))
    integer :: j, m

    call start(x, y, forced, s, .true., a, in, r, status, msg)
    if (status /= MLID_OK) return
    m = size(forced)
    do
      j = best_entry(a, in, size(y))
      if (j == 0) exit
      if (f_enter(a, j, count(in), size(y)) < s%f_in) exit
      call step(a, j, in, y, r, status, msg)
      if (status /= MLID_OK) return
      do
        j = worst_term(a, in, forced, size(y))
        if (j == 0) exit
        if (f_remove(a, j, count(in), size(y)) >= s%f_out) exit
        call step(a, j, in, y, r, status, msg)
        if (status /= MLID_OK) return
      end do
    end do
    call regression_finish(x, y, in, a, r, status, msg)
  end subroutine stepwise_forward

  !> Backward elimination from all candidates of x (N, m) for y, the
  !> forced ones always in.  Needs N above m + 1 and no candidate a
  !> combination of the others.
  subroutine stepwise_backward(x, y, forced, s, r, status, msg)
    real(wp), intent(in) :: x(:, :), y(:)
    logical, intent(in) :: forced(:)
    type(regression_settings_t), intent(in) :: s
    type(regression_t), intent(out) :: r
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: a(:, :)
    logical :: in(size(forced))
    integer :: j, m, ny

    m = size(forced)
    if (size(y) <= m + 1) then
      status = MLID_ERR_INPUT
      msg = 'backward elimination: '//itoa(size(y))//' samples are too few for '// &
            itoa(m)//' candidates'
      return
    end if
    call start(x, y, forced, s, .false., a, in, r, status, msg)
    if (status /= MLID_OK) return
    ny = m + 1
    do j = 1, m
      if (in(j)) cycle
      if (a(j, j) <= TOL) then
        status = MLID_ERR_INPUT
        msg = 'backward elimination: candidate '//itoa(j)//' is (nearly) a combination of '// &
              'the candidates before it'
        return
      end if
      call sweep(a, j, .true.)
      in(j) = .true.
    end do
    r%nsteps = -1                        ! the start is the model of all candidates
    call path_add(r, 0, 0.0_wp, y, m, a(ny, ny)*dot_product(y, y), status, msg)
    if (status /= MLID_OK) return
    do
      j = worst_term(a, in, forced, size(y))
      if (j == 0) exit
      if (f_remove(a, j, count(in), size(y)) >= s%f_out) exit
      call step(a, j, in, y, r, status, msg)
      if (status /= MLID_OK) return
    end do
    call regression_finish(x, y, in, a, r, status, msg)
  end subroutine stepwise_backward

  !> Checked input, the cross products with the forced terms swept in, and
  !> the path's start (room for 10 (m + 1) steps: with F_out <= F_in far
  !> more than a selection takes).
  subroutine start(x, y, forced, s, entering, a, in, r, status, msg)
    real(wp), intent(in) :: x(:, :), y(:)
    logical, intent(in) :: forced(:)
    type(regression_settings_t), intent(in) :: s
    logical, intent(in) :: entering     !< forward selection: F_in checked too
    real(wp), allocatable, intent(out) :: a(:, :)
    logical, intent(out) :: in(:)
    type(regression_t), intent(out) :: r
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: j, m
    in = .false.
    call regression_check(x, y, forced, s, entering, .true., status, msg)
    if (status /= MLID_OK) return
    m = size(forced)
    allocate (a(m + 1, m + 1), stat=j)
    if (j /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'model structure: out of memory for '//itoa(m + 1)//' x '//itoa(m + 1)//' values'
      return
    end if
    call cross_products(x, y, a, status, msg)
    if (status /= MLID_OK) return
    do j = 1, m
      if (.not. forced(j)) cycle
      if (a(j, j) <= TOL) then
        status = MLID_ERR_INPUT
        msg = 'model structure: forced term '//itoa(j)//' is (nearly) a combination of '// &
              'the forced terms before it'
        return
      end if
      call sweep(a, j, .true.)
      in(j) = .true.
    end do
    call path_start(r, m, 10*(m + 1), y, s, count(in), a(m + 1, m + 1)*dot_product(y, y), &
                    status, msg)
  end subroutine start

  !> Term j in or out (whichever it is not) and the step on the path.
  subroutine step(a, j, in, y, r, status, msg)
    real(wp), intent(inout) :: a(:, :)
    integer, intent(in) :: j
    logical, intent(inout) :: in(:)
    real(wp), intent(in) :: y(:)
    type(regression_t), intent(inout) :: r
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: f
    integer :: ny, n
    ny = size(a, 1)
    n = size(y)
    if (in(j)) then
      f = f_remove(a, j, count(in), n)
    else
      f = f_enter(a, j, count(in), n)
    end if
    call sweep(a, j, .not. in(j))
    in(j) = .not. in(j)
    call path_add(r, merge(j, -j, in(j)), f, y, count(in), a(ny, ny)*dot_product(y, y), &
                  status, msg)
  end subroutine step

  !> The candidate out of the model with the largest F to enter (0: none
  !> can enter).
  integer function best_entry(a, in, n) result(best)
    real(wp), intent(in) :: a(:, :)
    logical, intent(in) :: in(:)
    integer, intent(in) :: n
    real(wp) :: f, fbest
    integer :: j
    best = 0
    fbest = 0.0_wp
    do j = 1, size(in)
      if (in(j)) cycle
      f = f_enter(a, j, count(in), n)
      if (f > fbest) then
        best = j
        fbest = f
      end if
    end do
  end function best_entry

  !> The term in the model, not forced, with the smallest F to remove (0:
  !> none).
  integer function worst_term(a, in, forced, n) result(worst)
    real(wp), intent(in) :: a(:, :)
    logical, intent(in) :: in(:), forced(:)
    integer, intent(in) :: n
    real(wp) :: f, fworst
    integer :: j
    worst = 0
    fworst = huge(1.0_wp)
    do j = 1, size(in)
      if (.not. in(j) .or. forced(j)) cycle
      f = f_remove(a, j, count(in), n)
      if (f < fworst .or. worst == 0) then
        worst = j
        fworst = f
      end if
    end do
  end function worst_term

end module mlid_stepwise
