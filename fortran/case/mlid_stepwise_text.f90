!> The texts of model-structure determination that both front ends show
!> alike (the deck's job 'stepwise', mlid_job_stepwise; Python's
!> mlid.stepwise_candidates and ModelStructure.deck_text ask for them):
!> the candidates' names, and a selected model as the lines of a deck's
!> &model group (the start of an output-error fit).
module mlid_stepwise_text
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: itoa, utf8_head, name_lines
  use mlid_candidates, only: candidate_terms
  implicit none
  private
  public :: CANDLEN, CONSTANT, candidate_names, candidate_list, candidate_lines, model_start_text, &
            g_text

  !> A candidate's name at the most ('al*be^2', '(al-0.03)+^2').
  integer, parameter :: CANDLEN = 64
  !> The constant's name: the longitudinal model's regressor '1'.
  character(len=*), parameter :: CONSTANT = '1'

contains

  !> The names of candidate_terms' columns: each product of the variables
  !> vnames by its exponents powers (nv, nt): 'al', 'al*de', 'al^2'; then
  !> each spline term: '(v-k)+', or '(v-k)+^n' for spline_degree n > 1
  !> (k as %g writes it).  A name longer than CANDLEN is refused.
  subroutine candidate_names(vnames, powers, knot_var, knots, spline_degree, names, status, msg)
    character(len=*), intent(in) :: vnames(:)
    integer, intent(in) :: powers(:, :), knot_var(:), spline_degree
    real(wp), intent(in) :: knots(:)
    character(len=CANDLEN), allocatable, intent(out) :: names(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=:), allocatable :: s
    integer :: j, i
    allocate (names(size(powers, 2) + size(knots)))
    status = MLID_OK
    msg = ''
    do j = 1, size(names)
      if (j <= size(powers, 2)) then
        s = ''
        do i = 1, size(vnames)
          if (powers(i, j) == 0) cycle
          if (len(s) > 0) s = s//'*'
          s = s//trim(vnames(i))
          if (powers(i, j) > 1) s = s//'^'//itoa(powers(i, j))
        end do
      else
        i = j - size(powers, 2)
        s = '('//trim(vnames(knot_var(i)))//'-'//g_text(knots(i), 6)//')+'
        if (spline_degree > 1) s = s//'^'//itoa(spline_degree)
      end if
      call check_length(s, status, msg)
      if (status /= MLID_OK) return
      names(j) = s
    end do
  end subroutine candidate_names

  !> The names of text, one a line (mlid_text's name_lines), as candidates'
  !> names: a line longer than CANDLEN is refused.
  subroutine candidate_lines(text, names, status, msg)
    character(len=*), intent(in) :: text
    character(len=CANDLEN), allocatable, intent(out) :: names(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: p, e
    p = 1
    do
      e = index(text(p:), achar(10))
      if (e == 0) exit
      call check_length(text(p:p + e - 2), status, msg)
      if (status /= MLID_OK) return
      p = p + e
    end do
    status = MLID_OK
    msg = ''
    call name_lines(text, names)
  end subroutine candidate_lines

  !> A candidate's name fits in CANDLEN bytes: cut, two names could meet,
  !> and forced terms and the model start would name the wrong term.
  subroutine check_length(name, status, msg)
    character(len=*), intent(in) :: name
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    status = MLID_OK
    msg = ''
    if (len(name) <= CANDLEN) return
    status = MLID_ERR_INPUT
    msg = 'candidate '''//utf8_head(name, 120)//trim(merge('...', '   ', len(name) > 120))// &
          ''' is longer than a candidate''s name may be ('//itoa(CANDLEN)//' bytes)'
  end subroutine check_length

  !> The candidates' names that the variables vnames give (candidate_terms'
  !> order), without their data: the checks of a deck's &stepwise.
  subroutine candidate_list(vnames, degree, knot_var, knots, spline_degree, names, status, msg)
    character(len=*), intent(in) :: vnames(:)
    integer, intent(in) :: degree, knot_var(:), spline_degree
    real(wp), intent(in) :: knots(:)
    character(len=CANDLEN), allocatable, intent(out) :: names(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: x(:, :)
    integer, allocatable :: powers(:, :)
    real(wp) :: one(1, size(vnames))
    one = 1.0_wp
    call candidate_terms(one, degree, knot_var, knots, spline_degree, x, powers, status, msg)
    if (status /= MLID_OK) return
    call candidate_names(vnames, powers, knot_var, knots, spline_degree, names, status, msg)
  end subroutine candidate_list

  !> A selected model as two lines of a deck's &model group: the item
  !> '<coefficient>_regressors' with the terms' names, and '<coefficient>'
  !> with their values (%.10g), each line ending in a comma.
  function model_start_text(coefficient, names, values) result(text)
    character(len=*), intent(in) :: coefficient, names(:)
    real(wp), intent(in) :: values(:)
    character(len=:), allocatable :: text
    integer :: k
    text = '    '//trim(coefficient)//'_regressors = '
    do k = 1, size(names)
      text = text//''''//quoted(trim(names(k)))//''''
      if (k < size(names)) text = text//', '
    end do
    text = text//','//achar(10)//'    '//trim(coefficient)//' = '
    do k = 1, size(values)
      text = text//g_text(values(k), 10)
      if (k < size(values)) text = text//', '
    end do
    text = text//','
  end function model_start_text

  !> name with each quote doubled (a deck's quoted text).
  function quoted(name) result(s)
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    do k = 1, len(name)
      s = s//name(k:k)
      if (name(k:k) == '''') s = s//''''
    end do
  end function quoted

  !> x in the fewest characters of p significant digits, as C's and
  !> Python's %.pg: fixed where the exponent X of x rounded to p digits is
  !> -4 <= X < p, else d.ddde+XX; trailing zeros and a trailing point
  !> dropped ('0.03', '-8', '1.5e+07', '1e-05', 'nan', 'inf').
  function g_text(x, p) result(text)
    real(wp), intent(in) :: x
    integer, intent(in) :: p
    character(len=:), allocatable :: text, mant
    character(len=64) :: buf
    integer :: e, k
    if (ieee_is_nan(x)) then
      text = 'nan'
      return
    else if (.not. ieee_is_finite(x)) then
      text = merge('inf ', '-inf', x > 0.0_wp)
      text = trim(text)
      return
    else if (x == 0.0_wp) then
      text = '0'
      return
    end if
    write (buf, '(es40.'//itoa(p - 1)//'e4)') x
    buf = adjustl(buf)
    k = index(buf, 'E')
    read (buf(k + 1:), *) e
    if (e >= -4 .and. e < p) then
      write (buf, '(f40.'//itoa(max(p - 1 - e, 0))//')') x
      text = strip_zeros(trim(adjustl(buf)))
      if (text(1:1) == '.') text = '0'//text
      if (text(1:min(2, len(text))) == '-.') text = '-0'//text(2:)
    else
      mant = strip_zeros(buf(1:k - 1))
      text = mant//'e'//merge('-', '+', e < 0)
      if (abs(e) < 10) text = text//'0'
      text = text//itoa(abs(e))
    end if
  end function g_text

  !> A decimal's trailing zeros after its point dropped, then the point.
  function strip_zeros(s) result(t)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: t
    integer :: k
    t = trim(s)
    if (index(t, '.') == 0) return
    k = len(t)
    do while (t(k:k) == '0')
      k = k - 1
    end do
    if (t(k:k) == '.') k = k - 1
    t = t(1:k)
  end function strip_zeros

end module mlid_stepwise_text
