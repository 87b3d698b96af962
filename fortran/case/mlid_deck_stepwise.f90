!> The reader of a deck's &stepwise group (mlid_deck; job 'stepwise',
!> mlid_job_stepwise): model-structure determination of each of &data's
!> outputs from candidates made of its inputs.
submodule (mlid_deck) mlid_deck_stepwise
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_text, only: choices
  use mlid_stepwise_text, only: CANDLEN, CONSTANT, candidate_list
  use mlid_structure, only: STRUCTURE_METHODS
  implicit none

  integer, parameter :: MAXKNOT = 100, MAXFORCED = 100

contains

  !> &stepwise: the method and its thresholds, the candidates (products of
  !> &data's inputs to degree, spline knots), the constant, the forced
  !> terms, the outputs' model-start names and the file of the model start.
  module procedure read_stepwise_group
    character(len=16) :: method
    character(len=PATHLEN) :: out
    character(len=CHANLEN) :: knot_vars(MAXKNOT)
    character(len=CANDLEN) :: forced(MAXFORCED)
    character(len=NAMELEN) :: coefficients(MAXY)
    real(wp) :: f_in, f_out, sig2_max, knots(MAXKNOT)
    integer :: degree, spline_degree, ios, nk
    logical :: intercept
    character(len=msg_len) :: iomsg
    character(len=:), allocatable :: gtext
    real(wp), allocatable :: kv(:)
    namelist /stepwise/ method, f_in, f_out, sig2_max, degree, knot_vars, knots, &
      spline_degree, intercept, forced, coefficients, out

    method = 'forward'
    f_in = 4.0_wp
    f_out = 4.0_wp
    sig2_max = 0.0_wp
    degree = 1
    spline_degree = 1
    knot_vars = ''
    knots = 0.0_wp
    intercept = .true.
    forced = ''
    coefficients = ''
    out = ''
    call no_model(c)
    call at_most(rd, c, 'stepwise', ['knot_vars', 'knots    '], MAXKNOT, 'spline knots')
    call at_most(rd, c, 'stepwise', ['forced'], MAXFORCED, 'forced terms')
    call at_most(rd, c, 'stepwise', ['coefficients'], MAXY, 'outputs')
    if (c%status /= MLID_OK) return
    gtext = group_text(rd, 'stepwise')
    ios = -1                          ! missing
    if (len(gtext) > 0) read (gtext, nml=stepwise, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'stepwise', ios, iomsg, .false., c)
    if (c%status /= MLID_OK) return
    if (too_long(rd, c, 'stepwise', ['method'], len(method))) return
    if (too_long(rd, c, 'stepwise', ['forced'], len(forced))) return
    if (too_long(rd, c, 'stepwise', ['coefficients'], len(coefficients))) return
    call take_list(rd, c, 'stepwise', 'knots', knots, kv, .false.)
    if (c%status /= MLID_OK) return
    nk = count(len_trim(knot_vars) > 0)
    associate (s => c%stepwise)
      s%method = to_lower(method)
      s%f_in = f_in
      s%f_out = f_out
      s%sig2_max = sig2_max
      s%degree = degree
      s%spline_degree = spline_degree
      s%intercept = intercept
      s%knots = kv
      s%forced = pack(forced, len_trim(forced) > 0)
      s%coefficients = pack(coefficients, len_trim(coefficients) > 0)
    end associate
    c%out_file = out
    call check_settings(rd, c, nk)
    if (c%status == MLID_OK) call check_names(c, knot_vars(1:nk))
    if (c%status == MLID_OK) call check_starts(c)
  end procedure read_stepwise_group

  !> Each output's model start names its own &model item (the outputs'
  !> names in lower case may meet: CL and Cl).
  subroutine check_starts(c)
    type(case_t), intent(inout) :: c
    character(len=NAMELEN) :: item(c%ny)
    integer :: i, j
    item = to_lower(c%chan%outputs)
    if (size(c%stepwise%coefficients) == c%ny) item = c%stepwise%coefficients
    do i = 2, c%ny
      j = findloc(item(1:i - 1), item(i), 1)
      if (j == 0) cycle
      call fail(c, 'group &stepwise: outputs '''//trim(c%chan%outputs(j))//''' and '''// &
                trim(c%chan%outputs(i))//''' both start &model item '''//trim(item(i))// &
                ''': name each output''s item in coefficients')
      return
    end do
  end subroutine check_starts

  !> A stepwise case has no &model: the parts every case shows by name
  !> (mlid_case's case_values) empty.
  subroutine no_model(c)
    type(case_t), intent(inout) :: c
    allocate (c%iconst(0), c%rconst(0), c%theta(0), c%isfree(0), c%labels(0), &
              c%initial_states(0))
    allocate (c%tie%to(0), c%tie%from(0), c%tie%scale(0), c%tie%offset(0))
  end subroutine no_model

  !> The method, the thresholds it uses (a threshold it does not use is
  !> refused when given: the report would show a setting that did nothing),
  !> sig2_max, the degrees and the knots.
  subroutine check_settings(rd, c, nk)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    integer, intent(in) :: nk
    associate (s => c%stepwise)
      if (all(STRUCTURE_METHODS /= s%method)) then
        call fail(c, 'group &stepwise: method must be '//choices(STRUCTURE_METHODS)//', not '''// &
                  trim(s%method)//'''')
      else if (is_given(rd, 'stepwise', 'f_in') .and. .not. s%uses_f_in()) then
        call fail(c, 'group &stepwise: f_in (the partial F to enter) is for method '// &
                  '''forward'', not '''//trim(s%method)//'''')
      else if (is_given(rd, 'stepwise', 'f_out') .and. .not. s%uses_f_out()) then
        call fail(c, 'group &stepwise: f_out (the partial F to stay) is for methods '// &
                  '''forward'' and ''backward'', not '''//trim(s%method)//'''')
      else if (s%uses_f_in() .and. .not. (s%f_in > 0.0_wp .and. s%f_out > 0.0_wp .and. &
                                          s%f_out <= s%f_in .and. ieee_is_finite(s%f_in))) then
        call fail(c, 'group &stepwise: f_in and f_out (the partial F to enter and to stay) '// &
                  'must be > 0 and finite with f_out <= f_in')
      else if (s%uses_f_out() .and. .not. (s%f_out > 0.0_wp .and. ieee_is_finite(s%f_out))) then
        call fail(c, 'group &stepwise: f_out (the partial F to stay) must be > 0 and finite')
      else if (.not. (s%sig2_max >= 0.0_wp .and. ieee_is_finite(s%sig2_max))) then
        call fail(c, 'group &stepwise: sig2_max must be >= 0 (0: the variance of each output) '// &
                  'and finite')
      else if (s%degree < 1 .or. s%degree > 10 .or. s%spline_degree < 1 .or. &
               s%spline_degree > 10) then
        call fail(c, 'group &stepwise: degree and spline_degree must be 1 to 10')
      else if (nk /= size(s%knots)) then
        call fail(c, 'group &stepwise: knot_vars and knots take one entry per knot, given '// &
                  itoa(nk)//' and '//itoa(size(s%knots)))
      else if (.not. all(ieee_is_finite(s%knots))) then
        call fail(c, 'group &stepwise: knots must be finite')
      else if (all(size(s%coefficients) /= [0, c%ny])) then
        call fail(c, 'group &stepwise: coefficients takes one name per output ('//itoa(c%ny)// &
                  ', the model start''s &model items), got '//itoa(size(s%coefficients)))
      end if
    end associate
  end subroutine check_settings

  !> The knots' variables among &data's inputs, the forced terms among the
  !> candidates they make, no input named as the constant.
  subroutine check_names(c, knot_vars)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: knot_vars(:)
    character(len=CANDLEN), allocatable :: names(:)
    integer :: k, status
    character(len=msg_len) :: msg
    associate (s => c%stepwise, v => c%chan%inputs)
      allocate (s%knot_var(size(knot_vars)))
      do k = 1, size(knot_vars)
        s%knot_var(k) = findloc(v, knot_vars(k), 1)
        if (s%knot_var(k) == 0) then
          call fail(c, 'group &stepwise: knot_vars '''//trim(knot_vars(k))//''' is not one of '// &
                    '&data''s input_cols (the variables)')
          return
        end if
      end do
      if (size(v) == 0) then
        call fail(c, 'group &stepwise: &data''s input_cols (the variables the candidates are '// &
                  'made of) are missing')
        return
      end if
      call candidate_list(v, s%degree, s%knot_var, s%knots, s%spline_degree, names, status, msg)
      if (status /= MLID_OK) then
        call fail(c, 'group &stepwise: '//trim(msg))
        return
      end if
      if (s%intercept .and. any(names == CONSTANT)) then
        call fail(c, 'group &stepwise: a variable is named '''//CONSTANT//''', the constant''s '// &
                  'name: set intercept = F to give the constant yourself')
        return
      end if
      if (s%intercept) names = [character(len=CANDLEN) :: CONSTANT, names]
      do k = 1, size(s%forced)
        if (all(names /= s%forced(k))) then
          call fail(c, 'group &stepwise: forced term '''//trim(s%forced(k))//''' is not among '// &
                    'the '//itoa(size(names))//' candidates')
          return
        end if
      end do
    end associate
  end subroutine check_names

end submodule mlid_deck_stepwise
