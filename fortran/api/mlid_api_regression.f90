!> The flat interface's model-structure determination for equation-error
!> models: stepwise regression and orthogonal functions (fortran/
!> estimation/regression).  Conventions: mlid_api_deck's comment.
module mlid_api_regression
  use, intrinsic :: iso_c_binding, only: c_int, c_int64_t
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_regression, only: regression_settings_t, regression_t
  use mlid_structure, only: model_structure, uses_f_in, uses_f_out
  use mlid_candidates, only: candidate_terms
  use mlid_handles, only: session_t, call_session
  use mlid_stepwise_text, only: CANDLEN, candidate_names, candidate_lines, model_start_text
  use mlid_text, only: join_lines, itoa
  implicit none
  private
  public :: mlid_model_structure, mlid_candidate_terms, mlid_model_start_text

contains

  !> The model structure of handle h's given values (mlid_api_values):
  !> x (N, m) the candidates, y (N), forced (m; 1: always in), method
  !> ('forward', 'backward' or 'mof'), f_in and f_out where the method uses
  !> them (default 4; refused where it does not), sig2_max (0: the
  !> variance of y).  Results: selected (m; 1 in), theta, sigma, f (m; F to
  !> remove where selected, to enter where not), r2, s, pse, sig2_max, and
  !> the path (steps 0..): term (+j in, -j out, 0 the start), np, f, r2,
  !> pse, s.
  subroutine mlid_model_structure(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    real(wp), allocatable :: x(:, :), y(:)
    integer, allocatable :: forced(:)
    character(len=:), allocatable :: method
    type(regression_settings_t) :: set
    type(regression_t) :: r
    integer :: k, st

    call call_session(h, s, st, msg)
    status = st
    if (st /= MLID_OK) return
    associate (g => s%given)
      call g%get('x', x, st, msg)
      call g%get('y', y, st, msg, [size(x, 1)])
      call g%get('forced', forced, st, msg, [size(x, 2)])
      call g%get('method', method, st, msg)
      call g%get('sig2_max', set%sig2_max, st, msg)
      ! a threshold given that the method does not use would be ignored
      if (st == MLID_OK .and. g%find('f_in') > 0) then
        call g%get('f_in', set%f_in, st, msg)
        if (.not. uses_f_in(method)) call unused('f_in (the partial F to enter)', method, &
                                                  st, msg)
      end if
      if (st == MLID_OK .and. g%find('f_out') > 0) then
        call g%get('f_out', set%f_out, st, msg)
        if (.not. uses_f_out(method)) call unused('f_out (the partial F to stay)', method, &
                                                   st, msg)
      end if
    end associate
    if (st == MLID_OK) call model_structure(method, x, y, forced /= 0, set, r, st, msg)
    status = st
    if (st /= MLID_OK) return
    k = r%nsteps
    call s%results%put('selected', merge(1, 0, r%selected))
    call s%results%put('theta', r%theta)
    call s%results%put('sigma', r%sigma)
    call s%results%put('f', r%f)
    call s%results%put('r2', r%r2)
    call s%results%put('s', r%s)
    call s%results%put('pse', r%pse)
    call s%results%put('sig2_max', r%sig2_max)
    call s%results%put('term', r%term(0:k))
    call s%results%put('np', r%np(0:k))
    call s%results%put('path_f', r%path_f(0:k))
    call s%results%put('path_r2', r%path_r2(0:k))
    call s%results%put('path_pse', r%path_pse(0:k))
    call s%results%put('path_s', r%path_s(0:k))
  end subroutine mlid_model_structure

  !> A threshold given that the method does not use: one line.
  subroutine unused(what, method, st, msg)
    character(len=*), intent(in) :: what, method
    integer, intent(out) :: st
    character(len=*), intent(out) :: msg
    st = MLID_ERR_INPUT
    msg = 'model structure: '//what//' is not a setting of method '''// &
          method(1:min(len(method), 40))//''''
  end subroutine unused

  !> Candidate regressors (mlid_candidates) of handle h's given values: v
  !> (N, nv) the variables, vnames their names (one a line), degree,
  !> knot_var (nk; 1-based) and knots (nk) the splines' variables and
  !> knots, spline_degree.  Results: x (N, nt + nk) the candidates, powers
  !> (nv nt) the products' exponents, column by column, and names (one a
  !> line; mlid_stepwise_text, as the deck's job 'stepwise' names them).
  subroutine mlid_candidate_terms(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    real(wp), allocatable :: v(:, :), knots(:), x(:, :)
    integer, allocatable :: knot_var(:), powers(:, :)
    integer :: degree, spline_degree, st
    character(len=:), allocatable :: vtext
    character(len=CANDLEN), allocatable :: vnames(:), names(:)

    call call_session(h, s, st, msg)
    status = st
    if (st /= MLID_OK) return
    associate (g => s%given)
      call g%get('v', v, st, msg)
      call g%get('vnames', vtext, st, msg)
      call g%get('degree', degree, st, msg)
      call g%get('knot_var', knot_var, st, msg)
      call g%get('knots', knots, st, msg)
      call g%get('spline_degree', spline_degree, st, msg)
    end associate
    if (st == MLID_OK) call candidate_terms(v, degree, knot_var, knots, spline_degree, x, &
                                            powers, st, msg)
    status = st
    if (st /= MLID_OK) return
    call candidate_lines(vtext, vnames, st, msg)
    if (st == MLID_OK .and. size(vnames) /= size(v, 2)) then
      st = MLID_ERR_INPUT
      msg = itoa(size(vnames))//' names for '//itoa(size(v, 2))//' variables'
    end if
    if (st == MLID_OK) call candidate_names(vnames, powers, knot_var, knots, spline_degree, &
                                            names, st, msg)
    status = st
    if (st /= MLID_OK) then
      msg = 'candidates: '//msg
      return
    end if
    call s%results%put('x', x)
    call s%results%put('powers', reshape(powers, [size(powers)]))
    call s%results%put('names', join_lines(names))
  end subroutine mlid_candidate_terms

  !> A selected model as the lines of a deck's &model group (mlid_stepwise_
  !> text, the text the deck's job 'stepwise' prints) from handle h's given
  !> values: coefficient (the item's name), names (the terms, one a line)
  !> and values.  Result: text.
  subroutine mlid_model_start_text(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    character(len=:), allocatable :: coefficient, ntext
    character(len=CANDLEN), allocatable :: names(:)
    real(wp), allocatable :: values(:)
    integer :: st

    call call_session(h, s, st, msg)
    status = st
    if (st /= MLID_OK) return
    associate (g => s%given)
      call g%get('coefficient', coefficient, st, msg)
      call g%get('names', ntext, st, msg)
      call g%get('values', values, st, msg)
    end associate
    status = st
    if (st /= MLID_OK) return
    call candidate_lines(ntext, names, st, msg)
    if (st == MLID_OK .and. size(names) /= size(values)) then
      st = MLID_ERR_INPUT
      msg = itoa(size(names))//' names for '//itoa(size(values))//' values'
    end if
    status = st
    if (st /= MLID_OK) then
      msg = 'model start: '//msg
      return
    end if
    call s%results%put('text', model_start_text(coefficient, names, values))
  end subroutine mlid_model_start_text

end module mlid_api_regression
