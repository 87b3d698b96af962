!> Candidate regressors for model-structure determination (Klein and
!> Morelli 2006, sec. 5.4; Klein and Batterson's splines): from nv
!> variables (alpha, beta, rates, surfaces), every product of total degree
!> 1 to degree (each variable, then x_i x_j, x_i^2, ...), and spline terms
!> (x_i - k)+^n, zero below the knot.
module mlid_candidates
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_MEMORY
  use mlid_text, only: itoa
  implicit none
  private
  public :: candidate_terms, MAX_TERMS

  !> The most candidates a call makes (a bound on degree and variables).
  integer, parameter :: MAX_TERMS = 10000

contains

  !> x (N, nt + nk): the products of the variables v (N, nv) of degree 1 to
  !> degree, by degree, each degree's in lexicographic order of the
  !> variables' indices i1 <= i2 <= ... (powers (nv, nt) their exponents),
  !> then (v(:, knot_var(k)) - knots(k))+^spline_degree for each knot.
  subroutine candidate_terms(v, degree, knot_var, knots, spline_degree, x, powers, status, msg)
    real(wp), intent(in) :: v(:, :), knots(:)
    integer, intent(in) :: degree, knot_var(:), spline_degree
    real(wp), allocatable, intent(out) :: x(:, :)
    integer, allocatable, intent(out) :: powers(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: nv, nt, d, k, t, ierr
    integer, allocatable :: idx(:)

    call check(v, degree, knot_var, knots, spline_degree, nt, status, msg)
    if (status /= MLID_OK) return
    nv = size(v, 2)
    allocate (x(size(v, 1), nt + size(knots)), powers(nv, nt), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'candidates: out of memory for '//itoa(size(v, 1))//' x '// &
            itoa(nt + size(knots))//' values'
      return
    end if
    powers = 0
    t = 0
    do d = 1, degree
      idx = [(1, k=1, d)]
      do
        t = t + 1
        x(:, t) = 1.0_wp
        do k = 1, d
          x(:, t) = x(:, t)*v(:, idx(k))
          powers(idx(k), t) = powers(idx(k), t) + 1
        end do
        if (.not. next_combination(idx, nv)) exit
      end do
    end do
    do k = 1, size(knots)
      x(:, nt + k) = max(v(:, knot_var(k)) - knots(k), 0.0_wp)**spline_degree
    end do
  end subroutine candidate_terms

  !> The next nondecreasing index tuple in [1, nv] in lexicographic order
  !> (false after the last, nv nv ... nv).
  logical function next_combination(idx, nv) result(more)
    integer, intent(inout) :: idx(:)
    integer, intent(in) :: nv
    integer :: k
    more = .false.
    do k = size(idx), 1, -1
      if (idx(k) < nv) then
        idx(k:) = idx(k) + 1
        more = .true.
        return
      end if
    end do
  end function next_combination

  subroutine check(v, degree, knot_var, knots, spline_degree, nt, status, msg)
    real(wp), intent(in) :: v(:, :), knots(:)
    integer, intent(in) :: degree, knot_var(:), spline_degree
    integer, intent(out) :: nt, status
    character(len=*), intent(out) :: msg
    real(wp) :: count
    integer :: d
    nt = 0
    status = MLID_ERR_INPUT
    if (size(v, 1) < 1 .or. size(v, 2) < 1) then
      msg = 'candidates: no variables or no samples'
      return
    else if (degree < 1 .or. spline_degree < 1) then
      msg = 'candidates: the degree and the spline degree must be at least 1, not '// &
            itoa(degree)//' and '//itoa(spline_degree)
      return
    else if (size(knot_var) /= size(knots)) then
      msg = 'candidates: '//itoa(size(knot_var))//' knot variables for '// &
            itoa(size(knots))//' knots'
      return
    else if (size(knots) > 0) then
      if (any(knot_var < 1 .or. knot_var > size(v, 2))) then
        msg = 'candidates: a knot''s variable is not one of the '//itoa(size(v, 2))//' variables'
        return
      end if
    end if
    if (.not. (all(ieee_is_finite(v)) .and. all(ieee_is_finite(knots)))) then
      msg = 'candidates: the variables and the knots must be finite'
      return
    end if
    count = 0.0_wp                        ! C(nv + d - 1, d) products of degree d
    do d = 1, degree
      count = count + binomial(size(v, 2) + d - 1, d)
      if (count + size(knots) > MAX_TERMS) then
        msg = 'candidates: '//itoa(size(v, 2))//' variables to degree '//itoa(degree)// &
              ' make more than '//itoa(MAX_TERMS)//' candidates'
        return
      end if
    end do
    nt = nint(count)
    status = MLID_OK
    msg = ''
  end subroutine check

  pure real(wp) function binomial(n, k) result(c)
    integer, intent(in) :: n, k
    integer :: i
    c = 1.0_wp
    do i = 1, k
      c = c*real(n - k + i, wp)/real(i, wp)
    end do
  end function binomial

end module mlid_candidates
