!> The deck's job 'stepwise': the model structure of each of &data's
!> outputs (a measured aerodynamic coefficient) from candidate regressors
!> made of its inputs (mlid_candidates: products to a degree, spline
!> terms), by stepwise regression or orthogonal functions (fortran/
!> estimation/regression), as Python's mlid.stepwise does on the same
!> candidates.  Its report and JSON: each output's selection path, its
!> selected terms with estimates, sigma and partial F, R^2, s and PSE, and
!> the selected model as the lines of a deck's &model group (the start of
!> an output-error fit; mlid_stepwise_text), written to &stepwise's out
!> when it names a file.
module mlid_job_stepwise
  use mlid_kinds, only: wp, MLID_OK, msg_len
  use mlid_case, only: case_t, stepwise_spec_t
  use mlid_deck, only: case_record
  use mlid_candidates, only: candidate_terms
  use mlid_regression, only: regression_settings_t, regression_t
  use mlid_structure, only: model_structure
  use mlid_stepwise_text, only: CANDLEN, CONSTANT, candidate_names, model_start_text
  use mlid_report, only: case_json, json_string, number, numbers, strings, integers
  use mlid_files, only: write_file
  use mlid_memory, only: no_memory
  use mlid_text, only: itoa, es_text, to_lower
  implicit none
  private
  public :: stepwise_job

  character, parameter :: NL = achar(10)

  !> One output's selection, its name and model-start item.
  type :: selection_t
    character(len=:), allocatable :: output, coefficient, start
    type(regression_t) :: r
  end type selection_t

contains

  !> Case c's job 'stepwise': report and json (empty when it failed), the
  !> model starts written to out when it names a file.
  subroutine stepwise_job(c, report, json, status, msg)
    type(case_t), intent(in) :: c
    character(len=:), allocatable, intent(inout) :: report, json
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: t(:), u(:, :), y(:, :), x(:, :)
    character(len=CANDLEN), allocatable :: names(:)
    type(selection_t), allocatable :: sel(:)
    character(len=:), allocatable :: starts
    integer :: i

    call case_record(c, t, u, y, status, msg)
    if (status == MLID_OK) call candidates(c, u, x, names, status, msg)
    if (status /= MLID_OK) return
    allocate (sel(c%ny))
    starts = ''
    do i = 1, c%ny
      call select_output(c, i, x, y(i, :), names, sel(i), status, msg)
      if (status /= MLID_OK) return
      starts = starts//sel(i)%start//NL
    end do
    if (len_trim(c%out_file) > 0) then
      call write_file(c%out_file, starts, status, msg)
      if (status /= MLID_OK) return
    end if
    report = stepwise_report(c, size(t), names, sel)
    json = stepwise_json(c, size(t), names, sel)
  end subroutine stepwise_job

  !> The candidates x (N, m) of &data's inputs u and their names, the
  !> constant first when the case adds it.
  subroutine candidates(c, u, x, names, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: u(:, :)
    real(wp), allocatable, intent(out) :: x(:, :)
    character(len=CANDLEN), allocatable, intent(out) :: names(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: xt(:, :)
    integer, allocatable :: powers(:, :)
    integer :: ierr
    associate (s => c%stepwise)
      call candidate_terms(transpose(u), s%degree, s%knot_var, s%knots, s%spline_degree, xt, &
                           powers, status, msg)
      if (status /= MLID_OK) return
      call candidate_names(c%chan%inputs, powers, s%knot_var, s%knots, s%spline_degree, names, &
                           status, msg)
      if (status /= MLID_OK) return
      if (s%intercept) then
        allocate (x(size(xt, 1), size(xt, 2) + 1), stat=ierr)     ! N up to MAX_SAMPLES
        if (ierr /= 0) then
          call no_memory('the candidates and the constant', real(size(xt, 1), wp)* &
                         real(size(xt, 2) + 1, wp), status, msg)
          return
        end if
        x(:, 1) = 1.0_wp
        x(:, 2:) = xt
        names = [character(len=CANDLEN) :: CONSTANT, names]
      else
        call move_alloc(xt, x)
      end if
    end associate
  end subroutine candidates

  !> Output i's selection from the candidates x by the case's method.
  subroutine select_output(c, i, x, y, names, sel, status, msg)
    type(case_t), intent(in) :: c
    integer, intent(in) :: i
    real(wp), intent(in) :: x(:, :), y(:)
    character(len=*), intent(in) :: names(:)
    type(selection_t), intent(out) :: sel
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(regression_settings_t) :: set
    logical :: forced(size(names))
    integer :: j
    associate (s => c%stepwise)
      set%f_in = s%f_in
      set%f_out = s%f_out
      set%sig2_max = s%sig2_max
      do j = 1, size(names)
        forced(j) = any(s%forced == names(j)) .or. (s%intercept .and. j == 1)
      end do
      call model_structure(trim(s%method), x, y, forced, set, sel%r, status, msg)
      sel%output = trim(c%chan%outputs(i))
      if (status /= MLID_OK) then
        msg = 'stepwise: output '//sel%output//': '//named_candidates(msg, names)
        return
      end if
      sel%coefficient = to_lower(sel%output)
      if (size(s%coefficients) > 0) sel%coefficient = trim(s%coefficients(i))
      sel%start = model_start_text(sel%coefficient, pack(names, sel%r%selected), &
                                   pack(sel%r%theta, sel%r%selected))
    end associate
  end subroutine select_output

  !> The core's 'candidate 12' and 'term 3' (counted from 1) as their names.
  function named_candidates(msg, names) result(text)
    character(len=*), intent(in) :: msg, names(:)
    character(len=:), allocatable :: text
    character(len=msg_len) :: rest
    integer :: k, e, j, ios
    text = ''
    rest = msg
    do
      k = first_of(index(rest, 'candidate '), index(rest, 'term '))
      if (k == 0) exit
      k = k + index(rest(k:), ' ') - 1          ! the blank after the word
      e = verify(rest(k + 1:)//'x', '0123456789') + k - 1
      read (rest(k + 1:e), *, iostat=ios) j
      if (e == k .or. ios /= 0 .or. j < 1 .or. j > size(names)) then
        text = text//rest(1:k)
        rest = rest(k + 1:)
        cycle
      end if
      text = text//rest(1:k)//''''//trim(names(j))//''''
      rest = rest(e + 1:)
    end do
    text = trim(text//rest)
  end function named_candidates

  !> The first of two places in a text (0: neither).
  pure integer function first_of(a, b) result(k)
    integer, intent(in) :: a, b
    k = max(a, b)
    if (a > 0 .and. b > 0) k = min(a, b)
  end function first_of

  function stepwise_report(c, n, names, sel) result(text)
    type(case_t), intent(in) :: c
    integer, intent(in) :: n
    character(len=*), intent(in) :: names(:)
    type(selection_t), intent(in) :: sel(:)
    character(len=:), allocatable :: text
    integer :: i, k, j
    associate (s => c%stepwise)
      text = ' model structure, '//trim(method_words(s%method))//thresholds_text(s)//': '//itoa(n)//' samples, '// &
             itoa(size(names))//' candidates of '//itoa(c%nu)//' variables (degree '// &
             itoa(s%degree)//', '//itoa(size(s%knots))//' spline knots'// &
             trim(merge(', the constant', '              ', s%intercept))//')'
      if (len_trim(c%out_file) > 0) text = text//'; model start to '//trim(c%out_file)
      text = text//NL
    end associate
    do i = 1, size(sel)
      associate (r => sel(i)%r)
        text = text//' output '//sel(i)%output//': '//itoa(count(r%selected))//' terms, R^2 '// &
               trim(adjustl(es_text(r%r2, 14, 6)))//', s '//trim(adjustl(es_text(r%s, 12, 4)))// &
               ', PSE '//trim(adjustl(es_text(r%pse, 12, 4)))//' (sig2_max '// &
               trim(adjustl(es_text(r%sig2_max, 12, 4)))//')'//NL
        text = text//'   step  '//pad('term', 20)//'        F            R^2            PSE'// &
               '              s  terms'//NL
        do k = 0, r%nsteps
          text = text//'   '//right(itoa(k), 4)//'  '//pad(step_term(r%term(k), names), 20)// &
                 es_text(r%path_f(k), 15, 4)//es_text(r%path_r2(k), 15, 6)// &
                 es_text(r%path_pse(k), 15, 4)//es_text(r%path_s(k), 15, 4)// &
                 right(itoa(r%np(k)), 7)//NL
        end do
        text = text//'   '//pad('term', 20)//'      estimate          sigma              F'//NL
        do j = 1, size(names)
          if (.not. r%selected(j)) cycle
          text = text//'   '//pad(names(j), 20)//es_text(r%theta(j), 15, 6)// &
                 es_text(r%sigma(j), 15, 4)//es_text(r%f(j), 15, 4)//NL
        end do
        text = text//'   model start (&model):'//NL//sel(i)%start//NL
      end associate
    end do
  end function stepwise_report

  function stepwise_json(c, n, names, sel) result(text)
    type(case_t), intent(in) :: c
    integer, intent(in) :: n
    character(len=*), intent(in) :: names(:)
    type(selection_t), intent(in) :: sel(:)
    character(len=:), allocatable :: text
    character(len=CANDLEN + 1), allocatable :: terms(:)     ! '+name', '-name'
    integer :: i, k
    text = case_json(c%title, c%job, 0, '', n, trim(c%out_file))
    text = text(1:len(text) - 1)//','//NL//'"method": '//json_string(trim(c%stepwise%method))
    if (c%stepwise%uses_f_in()) text = text//', "f_in": '//number(c%stepwise%f_in)
    if (c%stepwise%uses_f_out()) text = text//', "f_out": '//number(c%stepwise%f_out)
    text = text//','//NL//'"candidates": '//strings(names)//','//NL//'"outputs": ['
    do i = 1, size(sel)
      associate (r => sel(i)%r)
        allocate (terms(0:r%nsteps))
        do k = 0, r%nsteps
          terms(k) = step_term(r%term(k), names)
        end do
        if (i > 1) text = text//','
        text = text//NL//'{"output": '//json_string(sel(i)%output)//', "coefficient": '// &
               json_string(sel(i)%coefficient)//','//NL// &
               '"selected": '//strings(pack(names, r%selected))//','//NL// &
               '"estimates": '//numbers(pack(r%theta, r%selected))//','//NL// &
               '"sigma": '//numbers(pack(r%sigma, r%selected))//','//NL// &
               '"f": '//numbers(r%f)//','//NL// &
               '"r2": '//number(r%r2)//', "s": '//number(r%s)//', "pse": '//number(r%pse)// &
               ', "sig2_max": '//number(r%sig2_max)//','//NL// &
               '"path": {"term": '//strings(terms)//','//NL// &
               '"f": '//numbers(r%path_f(0:r%nsteps))//','//NL// &
               '"r2": '//numbers(r%path_r2(0:r%nsteps))//','//NL// &
               '"pse": '//numbers(r%path_pse(0:r%nsteps))//','//NL// &
               '"s": '//numbers(r%path_s(0:r%nsteps))//','//NL// &
               '"terms": '//integers(r%np(0:r%nsteps))//'},'//NL// &
               '"model_start": '//json_string(sel(i)%start)//'}'
        deallocate (terms)
      end associate
    end do
    text = text//']}'
  end function stepwise_json

  !> A step of the path in words: 'start', '+name' (entered), '-name' (left).
  function step_term(term, names) result(s)
    integer, intent(in) :: term
    character(len=*), intent(in) :: names(:)
    character(len=:), allocatable :: s
    if (term == 0) then
      s = 'start'
    else if (term > 0) then
      s = '+'//trim(names(term))
    else
      s = '-'//trim(names(-term))
    end if
  end function step_term

  !> The thresholds the method uses, as the report shows them: ' (F_in a,
  !> F_out b)' forward, ' (F_out b)' backward, none for mof (least PSE).
  function thresholds_text(s) result(text)
    type(stepwise_spec_t), intent(in) :: s
    character(len=:), allocatable :: text
    text = ''
    if (s%uses_f_in()) text = 'F_in '//trim(adjustl(es_text(s%f_in, 10, 3)))//', '
    if (s%uses_f_out()) text = text//'F_out '//trim(adjustl(es_text(s%f_out, 10, 3)))
    if (len(text) > 0) text = ' ('//text//')'
  end function thresholds_text

  function method_words(method) result(s)
    character(len=*), intent(in) :: method
    character(len=:), allocatable :: s
    select case (method)
    case ('backward')
      s = 'backward elimination with the partial F-test'
    case ('mof')
      s = 'multivariate orthogonal functions with PSE'
    case default
      s = 'stepwise regression with the partial F-test'
    end select
  end function method_words

  !> s left-justified in at least w characters.
  function pad(s, w) result(t)
    character(len=*), intent(in) :: s
    integer, intent(in) :: w
    character(len=:), allocatable :: t
    t = trim(s)
    if (len(t) < w) t = t//repeat(' ', w - len(t))
  end function pad

  !> s right-justified in at least w characters.
  function right(s, w) result(t)
    character(len=*), intent(in) :: s
    integer, intent(in) :: w
    character(len=:), allocatable :: t
    t = trim(s)
    if (len(t) < w) t = repeat(' ', w - len(t))//t
  end function right

end module mlid_job_stepwise
