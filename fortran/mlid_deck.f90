!> Batch decks: Fortran namelist groups, several cases stacked in one file.
!>
!> A case starts at each line whose first word is &case and holds the groups
!>   &case     title, job ('estimate' or 'simulate')
!>   &model    kind ('linear', 'longitudinal', 'x22' or 'user'), nx, nu, ny, nw, f, g,
!>             h, d, gamma (row by row), cd_regressors, cl_regressors,
!>             cm_regressors, cd, cl, cm, constants (longitudinal), p,
!>             user_iconst, user_rconst (user), x0, bias, q, r, s (noise
!>             variances, cross-covariance row by row), free, names, tie,
!>             input_hold, substeps, state_names, input_names, output_names
!>   &data     file, time_col, input_cols, output_cols, skip_rows   (estimate)
!>   &simulate out, t_end, dt, seed, noise_std, input_shape, amplitude,
!>             t_start, pulse_width                                  (simulate)
!>   &estimate method, startup, max_iter, halvings, noise, partials, steady_state,
!>             tol_cost, tol_step, tol_grad, rcond, prior, prior_weight,
!>             prior_decay, rank_min, rank_max, rank_rule, lower, upper (per free parameter, in the
!>             order of free)
!> A problem in one case is kept in that case (status, msg) and the others
!> are still read.  The Python reader (mlid/deck.py) follows the same rules.
module mlid_deck
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, msg_len, MLID_OK, MLID_ERR_INPUT
  use mlid_case, only: case_t, NAMELEN, PATHLEN, MAXSEG, MAX_SAMPLES
  use mlid_model_factory, only: MODEL_LINEAR, MODEL_AERO_LONG, MODEL_USER, MODEL_X22
  use mlid_x22, only: X22_LABELS
  use mlid_options, only: options_t, options_to_flat, options_from_flat, NOPT
  use mlid_inputs, only: input_signal
  use mlid_aero_long, only: REGRESSOR_NAMES, NREG
  use mlid_user_model, only: user_model_t, user_model_create
  implicit none
  private
  public :: case_t, deck_read, deck_open, case_record, case_time_input, manoeuvre_layout, &
            NAMELEN, PATHLEN

  !> The cases of the deck last opened by deck_open, for the flat interface.
  type(case_t), allocatable, protected, public :: opened(:)

  integer, parameter :: LINELEN = 2048
  integer, parameter :: MAXX = 30, MAXU = 10, MAXY = 30, MAXW = 10, MAXFREE = 200, MAXCOL = 100
  integer, parameter :: MAXR = 12, NBLOCK = 11
  !> Suffix of a longitudinal coefficient's default label, per regressor
  !> (C_D0, C_DV, C_Lalpha, C_mq, ...; python/mlid/model.py has the same).
  character(len=8), parameter :: SUFFIX(NREG) = &
    [character(len=8) :: '0', 'V', 'alpha', 'alpha2', 'q', 'de']
  real(wp), parameter :: UNSET = huge(1.0_wp)   !< marks array entries the deck did not give
  character(len=*), parameter :: GROUPS = ' case model data simulate estimate '


contains

  !> Read every case of a deck.  status /= 0 only when the deck as a whole
  !> cannot be used (missing file, no &case); per-case problems are kept in
  !> the cases.
  subroutine deck_read(path, cases, status, msg)
    character(len=*), intent(in) :: path
    type(case_t), allocatable, intent(out) :: cases(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=LINELEN), allocatable :: lines(:)
    integer, allocatable :: starts(:)
    integer :: n, k, last

    allocate (cases(0))
    call read_lines(path, lines, status, msg)
    if (status /= MLID_OK) return
    n = size(lines)
    allocate (starts(0))
    do k = 1, n
      if (first_word(lines(k)) == '&case') starts = [starts, k]
    end do
    if (size(starts) == 0) then
      status = MLID_ERR_INPUT
      msg = trim(path)//': no &case group found (a deck is a sequence of cases, each starting with &case)'
      return
    end if
    do k = 1, starts(1) - 1
      if (len_trim(strip_comment(lines(k))) > 0) then
        status = MLID_ERR_INPUT
        write (msg, '(a,i0,a)') trim(path)//' line ', k, ': text before the first &case group'
        return
      end if
    end do
    deallocate (cases)
    allocate (cases(size(starts)))
    do k = 1, size(starts)
      last = n
      if (k < size(starts)) last = starts(k + 1) - 1
      cases(k)%line = starts(k)
      call read_case(lines(starts(k):last), starts(k), cases(k))
      call resolve_paths(path, cases(k))
    end do
  end subroutine deck_read

  !> Read a deck and keep its cases (opened) for the flat interface.
  subroutine deck_open(path, ncases, status, msg)
    character(len=*), intent(in) :: path
    integer, intent(out) :: ncases, status
    character(len=*), intent(out) :: msg
    call deck_read(path, opened, status, msg)
    ncases = size(opened)
  end subroutine deck_open

  !> File names of a case are taken from the deck's folder unless absolute.
  subroutine resolve_paths(deck, c)
    character(len=*), intent(in) :: deck
    type(case_t), intent(inout) :: c
    character(len=:), allocatable :: dir
    integer :: k
    dir = ''
    if (index(deck, '/', back=.true.) > 0) dir = deck(1:index(deck, '/', back=.true.) - 1)
    if (allocated(c%data_files)) then
      do k = 1, size(c%data_files)
        c%data_files(k) = resolve(dir, c%data_files(k))
      end do
    end if
    if (len_trim(c%out_file) > 0) c%out_file = resolve(dir, c%out_file)
  end subroutine resolve_paths

  !> Parse one case from its lines (first is the &case line, number line0).
  subroutine read_case(lines, line0, c)
    character(len=*), intent(in) :: lines(:)
    integer, intent(in) :: line0
    type(case_t), intent(inout) :: c
    ! namelist variables, reset for every case
    character(len=128) :: title
    character(len=16) :: job, kind, input_hold, noise, method, startup, rank_rule, input_shape(MAXU)
    integer :: nx, nu, ny, nw, substeps, max_iter, halvings, time_col, skip_rows, seed
    real(wp) :: f(MAXX*MAXX), g(MAXX*MAXU), h(MAXY*MAXX), d(MAXY*MAXU), x0(MAXX), bias(MAXY)
    real(wp) :: gamma(MAXX*MAXW), q(MAXW), r(MAXY), s(MAXW*MAXY), k(MAXU*MAXX)
    character(len=8) :: cd_regressors(MAXR), cl_regressors(MAXR), cm_regressors(MAXR)
    real(wp) :: cd(MAXR), cl(MAXR), cm(MAXR), constants(9), p(MAXFREE), user_rconst(MAXFREE)
    integer :: user_iconst(MAXFREE)
    type(user_model_t) :: user
    character(len=8) :: bkey(NBLOCK)
    integer :: brow(NBLOCK), bcol(NBLOCK), boff(NBLOCK), ncoef(3), codes(3*MAXR)
    character(len=NAMELEN), allocatable :: default_label(:)
    logical :: partials, steady_state
    character(len=NAMELEN) :: free(MAXFREE), names(MAXFREE)
    character(len=2*NAMELEN + 1) :: tie(MAXFREE)
    character(len=NAMELEN) :: state_names(MAXX), input_names(MAXU), output_names(MAXY)
    real(wp) :: tol_cost, tol_step, tol_grad, rcond, prior_decay
    real(wp) :: prior(MAXFREE), prior_weight(MAXFREE), lower(MAXFREE), upper(MAXFREE)
    integer :: rank_min, rank_max, free_idx(MAXFREE), pos
    character(len=PATHLEN) :: file(MAXSEG), out
    integer :: input_cols(MAXCOL), output_cols(MAXCOL)
    real(wp) :: t_end, dt, noise_std(MAXY), amplitude(MAXU), t_start(MAXU), pulse_width(MAXU)
    namelist /case/ title, job
    namelist /model/ kind, nx, nu, ny, nw, f, g, h, d, gamma, k, x0, bias, q, r, s, free, names, &
      tie, input_hold, substeps, state_names, input_names, output_names, cd_regressors, &
      cl_regressors, cm_regressors, cd, cl, cm, constants, p, user_iconst, user_rconst
    namelist /data/ file, time_col, input_cols, output_cols, skip_rows
    namelist /simulate/ out, t_end, dt, seed, noise_std, input_shape, amplitude, t_start, &
      pulse_width
    namelist /estimate/ method, startup, max_iter, halvings, noise, partials, steady_state, tol_cost, &
      tol_step, tol_grad, rcond, prior, prior_weight, prior_decay, rank_min, rank_max, rank_rule, &
      lower, upper
    type(options_t) :: opt
    integer :: unit, ik, ios, np, idx, jdx, peq, nth
    logical :: found
    character(len=msg_len) :: iomsg
    character(len=LINELEN) :: text
    character(len=:), allocatable :: seen

    ! Write the case without comments to a scratch file: gfortran and the
    ! Python reader disagree on comments after a trailing comma.
    open (newunit=unit, status='scratch', action='readwrite', form='formatted')
    seen = ' '
    do ik = 1, size(lines)
      text = strip_comment(lines(ik))
      write (unit, '(a)') trim(text)
      call check_groups(text, line0 + ik - 1, c, seen)
      if (c%status /= MLID_OK) then
        close (unit)
        return
      end if
    end do

    title = ''
    job = ''
    call read_group('case')
    if (c%status /= MLID_OK) return
    c%title = title
    c%job = to_lower(job)
    if (c%job /= 'estimate' .and. c%job /= 'simulate') then
      call fail('group &case: job must be ''estimate'' or ''simulate'', got '''//trim(job)//'''')
      return
    end if

    kind = 'linear'
    nx = 0
    nu = 0
    ny = 0
    nw = 0
    f = UNSET
    gamma = UNSET
    k = UNSET
    q = UNSET
    r = UNSET
    s = UNSET
    tie = ''
    cd_regressors = ''
    cl_regressors = ''
    cm_regressors = ''
    cd = UNSET
    cl = UNSET
    cm = UNSET
    constants = UNSET
    p = UNSET
    user_iconst = -huge(1)
    user_rconst = UNSET
    g = UNSET
    h = UNSET
    d = UNSET
    x0 = UNSET
    bias = UNSET
    free = ''
    names = ''
    state_names = ''
    input_names = ''
    output_names = ''
    input_hold = 'linear'
    substeps = opt%substeps
    call read_group('model', required=.true.)
    if (c%status /= MLID_OK) return
    select case (to_lower(kind))
    case ('linear')
      c%mkind = MODEL_LINEAR
      allocate (c%iconst(0), c%rconst(0))
    case ('longitudinal')
      c%mkind = MODEL_AERO_LONG
      if (any([nx, nu, ny, nw] /= [0, 0, 0, 0] .and. [nx, nu, ny, nw] /= [4, 2, 7, 4])) then
        call fail('group &model: a longitudinal model has nx, nu, ny, nw = 4, 2, 7, 4')
        return
      end if
      nx = 4
      nu = 2
      ny = 7
      nw = 4
      call regressor_codes(cd_regressors, 1)
      call regressor_codes(cl_regressors, 2)
      call regressor_codes(cm_regressors, 3)
      if (c%status /= MLID_OK) return
      if (count(constants /= UNSET) /= 9) then
        call fail('group &model: constants needs 9 values: g, S/m, S cbar/Iy, lT/Iy, V0, m, '// &
                  'sigma_T, rho, cbar/2')
        return
      end if
      c%iconst = [ncoef, pack(codes, codes > 0)]
      c%rconst = constants
    case ('user')
      c%mkind = MODEL_USER
      c%iconst = pack(user_iconst, user_iconst /= -huge(1))
      c%rconst = pack(user_rconst, user_rconst /= UNSET)
      call user_model_create(c%iconst, c%rconst, user, ios, iomsg)
      if (ios /= MLID_OK) then
        call fail('group &model: '//trim(iomsg))
        return
      end if
      nx = user%nx
      nu = user%nu
      ny = user%ny
      nw = user%nw
      ncoef(1) = user%np
    case ('x22')
      c%mkind = MODEL_X22
      allocate (c%iconst(0), c%rconst(0))
      if (any([nx, nu, ny, nw] /= [0, 0, 0, 0] .and. [nx, nu, ny, nw] /= [4, 1, 7, 3])) then
        call fail('group &model: the X-22 model has nx, nu, ny, nw = 4, 1, 7, 3')
        return
      end if
      nx = 4
      nu = 1
      ny = 7
      nw = 3
      ncoef(1) = 23
    case default
      call fail('group &model: unknown kind '''//trim(kind)//''' (available: linear, '// &
                'longitudinal, x22, user)')
      return
    end select
    if (nx < 1 .or. nx > MAXX .or. nu < 0 .or. nu > MAXU .or. ny < 1 .or. ny > MAXY .or. &
        nw < 0 .or. nw > MAXW) then
      write (iomsg, '(a,4(1x,i0),a,4(1x,i0))') 'group &model: nx, nu, ny, nw =', nx, nu, ny, nw, &
        ' out of range; limits are', MAXX, MAXU, MAXY, MAXW
      call fail(iomsg)
      return
    end if
    c%nx = nx
    c%nu = nu
    c%ny = ny
    c%nw = nw
    ! The blocks of theta, in order: key, rows, columns (-1: a vector).
    if (c%mkind == MODEL_LINEAR) then
      call set_blocks([character(len=8) :: 'f', 'g', 'h', 'd', 'gamma', 'k', 'x0', 'bias', 'q', &
                       'r', 's'], [nx, nx, ny, ny, nx, nu, nx, ny, nw, ny, nw], &
                      [nx, nu, nx, nu, nw, nx, -1, -1, -1, -1, ny])
    else if (c%mkind == MODEL_USER .or. c%mkind == MODEL_X22) then
      call set_blocks([character(len=8) :: 'p', 'x0', 'bias', 'q', 'r', 's'], &
                      [ncoef(1), nx, ny, nw, ny, nw], [-1, -1, -1, -1, -1, ny])
    else
      call set_blocks([character(len=8) :: 'cd', 'cl', 'cm', 'x0', 'bias', 'q', 'r', 's'], &
                      [ncoef, nx, ny, nw, ny, nw], [-1, -1, -1, -1, -1, -1, -1, ny])
    end if
    np = boff(findloc(bkey, 'x0', 1))
    nth = sum(brow*merge(1, bcol, bcol < 0))
    allocate (c%theta(nth), c%isfree(nth), c%itie(nth), c%labels(nth))
    c%isfree = 0
    c%itie = 0
    c%labels = ''
    if (c%mkind == MODEL_LINEAR) then
      call put_matrix('f', f, nx, nx, 0, required=.true.)
      call put_matrix('g', g, nx, nu, nx*nx, required=nu > 0)
      call put_matrix('h', h, ny, nx, nx*nx + nx*nu, required=.true.)
      call put_matrix('d', d, ny, nu, nx*nx + nx*nu + ny*nx, required=.false.)
      call put_matrix('gamma', gamma, nx, nw, np - nx*nw - nu*nx, required=nw > 0)
      call put_matrix('k', k, nu, nx, np - nu*nx, required=.false.)
    else if (c%mkind == MODEL_USER .or. c%mkind == MODEL_X22) then
      call put_vector('p', p, ncoef(1), 0)
      if (ncoef(1) > 0 .and. count(p /= UNSET) == 0) call fail('group &model: p (the '// &
                                                               'model''s parameters) is missing')
    else
      call put_vector('cd', cd, ncoef(1), 0)
      call put_vector('cl', cl, ncoef(2), ncoef(1))
      call put_vector('cm', cm, ncoef(3), ncoef(1) + ncoef(2))
    end if
    call put_vector('x0', x0, nx, np)
    call put_vector('bias', bias, ny, np + nx)
    call put_vector('q', q, nw, np + nx + ny)
    call put_vector('r', r, ny, np + nx + ny + nw)
    call put_matrix('s', s, nw, ny, np + nx + ny + nw + ny, required=.false.)
    if (c%status /= MLID_OK) return
    do ik = 1, MAXFREE
      if (len_trim(free(ik)) == 0) cycle
      call element_index(free(ik), bkey, brow, bcol, boff, idx)
      if (idx == 0) then
        call fail('group &model: free parameter '''//trim(free(ik))// &
                  ''' does not exist ('//trim(block_list())//' within the dimensions)')
        return
      end if
      if (c%isfree(idx) == 1) then
        call fail('group &model: free parameter '''//trim(free(ik))//''' listed twice')
        return
      end if
      c%isfree(idx) = 1
      free_idx(count(len_trim(free(1:ik)) > 0)) = idx
      c%labels(idx) = default_label(idx)
      if (len_trim(names(ik)) > 0) c%labels(idx) = names(ik)
    end do
    if (count(len_trim(names) > 0) > count(len_trim(free) > 0)) then
      call fail('group &model: more names than free parameters')
      return
    end if
    c%labels = pack(c%labels, c%isfree == 1)
    do ik = 1, MAXFREE
      if (len_trim(tie(ik)) == 0) cycle
      peq = index(tie(ik), '=')
      idx = 0
      jdx = 0
      if (peq > 1) then
        call element_index(tie(ik)(1:peq - 1), bkey, brow, bcol, boff, idx)
        call element_index(tie(ik)(peq + 1:), bkey, brow, bcol, boff, jdx)
      end if
      if (idx == 0 .or. jdx == 0) then
        call fail('group &model: tie '''//trim(tie(ik))//''' must read ''a=b'' with two '// &
                  'parameters that exist')
        return
      end if
      c%itie(idx) = jdx
    end do
    select case (to_lower(input_hold))
    case ('linear')
      opt%hold = .false.
    case ('zoh')
      opt%hold = .true.
    case default
      call fail('group &model: input_hold must be ''linear'' or ''zoh'', got '''//trim(input_hold)//'''')
      return
    end select
    opt%substeps = substeps
    c%input_names = pack(input_names, len_trim(input_names) > 0)
    c%output_names = pack(output_names, len_trim(output_names) > 0)

    if (c%job == 'estimate') then
      file = ''
      time_col = 1
      input_cols = 0
      output_cols = 0
      skip_rows = 0
      call read_group('data', required=.true.)
      if (c%status /= MLID_OK) return
      c%data_files = pack(file, len_trim(file) > 0)
      c%time_col = time_col
      c%skip_rows = skip_rows
      c%input_cols = pack(input_cols, input_cols /= 0)
      c%output_cols = pack(output_cols, output_cols /= 0)
      if (size(c%data_files) == 0) then
        call fail('group &data: file is missing')
      else if (size(c%input_cols) /= nu .or. size(c%output_cols) /= ny) then
        write (iomsg, '(a,i0,a,i0,a,i0,a,i0,a)') 'group &data: ', size(c%input_cols), &
          ' input_cols and ', size(c%output_cols), ' output_cols given, the model has ', nu, &
          ' inputs and ', ny, ' outputs'
        call fail(iomsg)
      else if (any([c%input_cols, c%output_cols, time_col] < 1) .or. skip_rows < 0) then
        call fail('group &data: column numbers must be >= 1 and skip_rows >= 0')
      end if
      if (c%status /= MLID_OK) return

      max_iter = opt%max_iter
      halvings = opt%halvings
      noise = 'diagonal'
      method = 'output_error'
      startup = 'none'
      rank_rule = 'iteration'
      partials = opt%partials
      steady_state = opt%steady
      tol_cost = opt%tol_cost
      tol_step = opt%tol_step
      tol_grad = opt%tol_grad
      rcond = opt%rcond
      prior_decay = opt%prior_decay
      rank_min = opt%rank_min
      rank_max = opt%rank_max
      prior = UNSET
      prior_weight = UNSET
      lower = UNSET
      upper = UNSET
      call read_group('estimate')
      if (c%status /= MLID_OK) return
      call put_extras()
      if (c%status /= MLID_OK) return
      opt%prior_decay = prior_decay
      opt%rank_min = rank_min
      opt%rank_max = rank_max
      opt%max_iter = max_iter
      opt%halvings = halvings
      opt%tol_cost = tol_cost
      opt%tol_step = tol_step
      opt%tol_grad = tol_grad
      opt%rcond = rcond
      opt%partials = partials
      opt%steady = steady_state
      c%method = to_lower(method)
      opt%method = either('method', method, 'output_error', 'filter_error')
      opt%startup = either('startup', startup, 'none', 'equation_error')
      opt%rank_rule = either('rank_rule', rank_rule, 'iteration', 'staged')
      c%noise = to_lower(noise)
      opt%full_r = either('noise', noise, 'diagonal', 'full') == 1
      if (c%status /= MLID_OK) return
    else
      out = ''
      t_end = 0.0_wp
      dt = 0.0_wp
      seed = 0
      noise_std = UNSET
      input_shape = ''
      amplitude = UNSET
      t_start = UNSET
      pulse_width = UNSET
      call read_group('simulate', required=.true.)
      if (c%status /= MLID_OK) return
      c%out_file = out
      c%t_end = t_end
      c%dt = dt
      c%seed = seed
      ! one value serves every input; otherwise one per input
      c%input_shape = per_input_text(input_shape, nu, 'none')
      c%t_start = per_input(t_start, nu)
      c%pulse_width = per_input(pulse_width, nu)
      c%noise_std = pack(noise_std, noise_std /= UNSET)
      c%amplitude = pack(amplitude, amplitude /= UNSET)
      ! noise_std, when given, sets the measurement-noise variances r
      if (size(c%noise_std) == ny) c%theta(np + nx + ny + nw + 1:np + nx + ny + nw + ny) = c%noise_std**2
      if (size(c%amplitude) == 0) c%amplitude = [(0.0_wp, ik=1, nu)]
      if (len_trim(out) == 0) then
        call fail('group &simulate: out (the data file to write) is missing')
      else if (.not. (dt > 0.0_wp .and. t_end > dt)) then
        call fail('group &simulate: need dt > 0 and t_end > dt')
      else if (.not. (t_end/dt < real(MAX_SAMPLES, wp))) then
        write (iomsg, '(a,g0.6,a,i0,a)') 'group &simulate: t_end/dt = ', t_end/dt, &
          ' samples; at most ', MAX_SAMPLES, ' are allowed'
        call fail(iomsg)
      else if (size(c%noise_std) /= ny .and. size(c%noise_std) /= 0) then
        write (iomsg, '(a,i0,a,i0,a)') 'group &simulate: noise_std has ', size(c%noise_std), &
          ' values, the model has ', ny, ' outputs'
        call fail(iomsg)
      else if (size(c%amplitude) /= nu) then
        write (iomsg, '(a,i0,a,i0,a)') 'group &simulate: amplitude has ', size(c%amplitude), &
          ' values, the model has ', nu, ' inputs'
        call fail(iomsg)
      else if (seed < 0) then
        call fail('group &simulate: seed must be >= 0')
      else if (size(c%input_shape) /= nu .or. size(c%t_start) /= nu .or. &
               size(c%pulse_width) /= nu) then
        write (iomsg, '(a,i0,a)') 'group &simulate: input_shape, t_start and pulse_width take '// &
          'one value or one per input (', nu, ')'
        call fail(iomsg)
      end if
      if (c%status /= MLID_OK) return
    end if
    call options_to_flat(opt, c%iopt, c%ropt)
    call options_from_flat(c%iopt, c%ropt, opt, ios, iomsg)
    if (ios /= MLID_OK) then
      call fail(iomsg)
      return
    end if
    close (unit)

  contains

    !> A priori values and weights and bounds, given per free parameter in
    !> the order of free, into theta's order.
    subroutine put_extras()
      integer :: j, nfr
      nfr = count(c%isfree == 1)
      if (count(prior_weight /= UNSET) + count(prior /= UNSET) + count(lower /= UNSET) + &
          count(upper /= UNSET) == 0) return
      do j = 1, MAXFREE
        if (j > nfr .and. any([prior(j), prior_weight(j), lower(j), upper(j)] /= UNSET)) then
          write (iomsg, '(a,i0,a)') 'group &estimate: prior, prior_weight, lower and upper take '// &
            'one value per free parameter (', nfr, ')'
          call fail(iomsg)
          return
        end if
      end do
      allocate (c%prior(size(c%theta)), c%pweight(nfr, nfr), c%lower(size(c%theta)), &
                c%upper(size(c%theta)))
      c%prior = c%theta
      c%pweight = 0.0_wp
      c%lower = -huge(1.0_wp)
      c%upper = huge(1.0_wp)
      do j = 1, nfr
        pos = count(c%isfree(1:free_idx(j)) == 1)      ! its place among the free, theta order
        if (prior(j) /= UNSET) c%prior(free_idx(j)) = prior(j)
        if (prior_weight(j) /= UNSET) c%pweight(pos, pos) = prior_weight(j)
        if (lower(j) /= UNSET) c%lower(free_idx(j)) = lower(j)
        if (upper(j) /= UNSET) c%upper(free_idx(j)) = upper(j)
      end do
      if (count(prior_weight /= UNSET) > 0) c%use_prior = 1
      if (count(lower /= UNSET) + count(upper /= UNSET) > 0) c%use_bounds = 1
    end subroutine put_extras

    !> Record the block table and the default label of every entry: the
    !> canonical element name, or C_D0, C_Lalpha, ... for coefficients.
    subroutine set_blocks(keys, rows, cols)
      character(len=*), intent(in) :: keys(:)
      integer, intent(in) :: rows(:), cols(:)
      integer :: b, i, j, o
      bkey = ''
      brow = 0
      bcol = 0
      boff = 0
      o = 0
      do b = 1, size(keys)
        bkey(b) = keys(b)
        brow(b) = rows(b)
        bcol(b) = cols(b)
        boff(b) = o
        o = o + rows(b)*merge(1, cols(b), cols(b) < 0)
      end do
      do b = size(keys) + 1, NBLOCK
        boff(b) = o
      end do
      allocate (default_label(o))
      do b = 1, size(keys)
        if (cols(b) < 0) then
          do i = 1, rows(b)
            write (default_label(boff(b) + i), '(a,i0,a)') trim(keys(b))//'(', i, ')'
            if (b <= 3 .and. c%mkind == MODEL_AERO_LONG) default_label(boff(b) + i) = &
              'C_'//trim(merge('D', merge('L', 'm', b == 2), b == 1))// &
              trim(SUFFIX(codes((b - 1)*MAXR + i)))
            if (b == 1 .and. c%mkind == MODEL_X22) default_label(boff(b) + i) = X22_LABELS(i)
          end do
        else
          do j = 1, cols(b)
            do i = 1, rows(b)
              write (default_label(boff(b) + (j - 1)*rows(b) + i), '(a,i0,a,i0,a)') &
                trim(keys(b))//'(', i, ',', j, ')'
            end do
          end do
        end if
      end do
    end subroutine set_blocks

    function block_list() result(text)
      character(len=:), allocatable :: text
      integer :: b
      text = 'use'
      do b = 1, NBLOCK
        if (len_trim(bkey(b)) == 0) exit
        text = text//' '//trim(bkey(b))//trim(merge('(i,j)', '(i)  ', bcol(b) >= 0))
      end do
    end function block_list

    !> Regressor names of coefficient ic -> codes (and their count).
    subroutine regressor_codes(names_in, ic)
      character(len=*), intent(in) :: names_in(:)
      integer, intent(in) :: ic
      integer :: k, j, i
      ncoef(ic) = 0
      codes((ic - 1)*MAXR + 1:ic*MAXR) = 0
      do k = 1, size(names_in)
        if (len_trim(names_in(k)) == 0) cycle
        j = 0
        do i = 1, NREG
          if (trim(REGRESSOR_NAMES(i)) == trim(adjustl(names_in(k)))) j = i
        end do
        if (j == 0) then
          call fail('group &model: regressor '''//trim(names_in(k))//''' does not exist (use 1, '// &
                    'V/V0, alpha, alpha^2, qhat, de)')
          return
        end if
        ncoef(ic) = ncoef(ic) + 1
        codes((ic - 1)*MAXR + ncoef(ic)) = j
      end do
    end subroutine regressor_codes

    !> The values given, or the one value repeated for every input (zeros
    !> when none is given).
    function per_input(v, n) result(out)
      real(wp), intent(in) :: v(:)
      integer, intent(in) :: n
      real(wp), allocatable :: out(:)
      out = pack(v, v /= UNSET)
      if (size(out) == 0) out = [0.0_wp]
      if (size(out) == 1) out = spread(out(1), 1, n)
    end function per_input

    function per_input_text(v, n, default) result(out)
      character(len=*), intent(in) :: v(:), default
      integer, intent(in) :: n
      character(len=16), allocatable :: out(:)
      integer :: i
      out = pack(v, len_trim(v) > 0)
      if (size(out) == 0) out = [character(len=16) :: default]
      if (size(out) == 1) out = spread(out(1), 1, n)
      do i = 1, size(out)
        out(i) = to_lower(out(i))
      end do
    end function per_input_text

    !> Read one group; a missing optional group keeps the defaults.
    subroutine read_group(group, required)
      character(len=*), intent(in) :: group
      logical, intent(in), optional :: required
      rewind (unit)
      select case (group)
      case ('case');     read (unit, nml=case, iostat=ios, iomsg=iomsg)
      case ('model');    read (unit, nml=model, iostat=ios, iomsg=iomsg)
      case ('data');     read (unit, nml=data, iostat=ios, iomsg=iomsg)
      case ('simulate'); read (unit, nml=simulate, iostat=ios, iomsg=iomsg)
      case ('estimate'); read (unit, nml=estimate, iostat=ios, iomsg=iomsg)
      end select
      found = ios == 0
      if (ios < 0) then
        if (present(required)) then
          if (required) call fail('group &'//group//' is missing (job '''//trim(c%job)//''' needs it)')
        end if
      else if (ios > 0) then
        call fail('group &'//group//' (line '//itoa(group_line(lines, line0, group))// &
                  '): '//trim(iomsg))
      end if
    end subroutine read_group

    !> Place a row-by-row matrix of the deck into theta (column-major).
    subroutine put_matrix(key, v, nr, nc, offset, required)
      character(len=*), intent(in) :: key
      real(wp), intent(in) :: v(:)
      integer, intent(in) :: nr, nc, offset
      logical, intent(in) :: required
      integer :: ngiven, i, j
      if (c%status /= MLID_OK) return
      ngiven = count(v /= UNSET)
      if (ngiven == 0 .and. .not. required) then
        c%theta(offset + 1:offset + nr*nc) = 0.0_wp
        return
      end if
      if (ngiven /= nr*nc .or. any(v(1:nr*nc) == UNSET)) then
        write (iomsg, '(a,i0,a,i0,a,i0,a,i0,a)') 'group &model: '//key//' has ', ngiven, &
          ' values, '//key//' is ', nr, 'x', nc, ' and needs ', nr*nc, ' (row by row)'
        call fail(iomsg)
        return
      end if
      do i = 1, nr
        do j = 1, nc
          c%theta(offset + (j - 1)*nr + i) = v((i - 1)*nc + j)
        end do
      end do
      if (.not. all(ieee_is_finite(c%theta(offset + 1:offset + nr*nc)))) &
        call fail('group &model: '//key//' has a value that is not finite')
    end subroutine put_matrix

    subroutine put_vector(key, v, n, offset)
      character(len=*), intent(in) :: key
      real(wp), intent(in) :: v(:)
      integer, intent(in) :: n, offset
      integer :: ngiven
      if (c%status /= MLID_OK) return
      ngiven = count(v /= UNSET)
      if (ngiven == 0) then
        c%theta(offset + 1:offset + n) = 0.0_wp
      else if (ngiven /= n .or. any(v(1:n) == UNSET)) then
        write (iomsg, '(a,i0,a,i0,a)') 'group &model: '//key//' has ', ngiven, &
          ' values, it needs ', n
        call fail(iomsg)
      else
        c%theta(offset + 1:offset + n) = v(1:n)
      end if
    end subroutine put_vector

    !> 0 or 1 for an &estimate keyword that must name one of two choices;
    !> anything else fails the case (the first such failure is the message).
    integer function either(key, given, name0, name1)
      character(len=*), intent(in) :: key, given, name0, name1
      either = -1
      if (c%status /= MLID_OK) return
      if (to_lower(given) == name0) then
        either = 0
      else if (to_lower(given) == name1) then
        either = 1
      else
        call fail('group &estimate: '//key//' must be '''//name0//''' or '''//name1// &
                  ''', got '''//trim(given)//'''')
      end if
    end function either

    subroutine fail(text)
      character(len=*), intent(in) :: text
      c%status = MLID_ERR_INPUT
      c%msg = text
      close (unit)
    end subroutine fail

  end subroutine read_case

  !> Flag a group name that is not one of GROUPS.
  subroutine check_groups(text, line, c, seen)
    character(len=*), intent(in) :: text
    integer, intent(in) :: line
    type(case_t), intent(inout) :: c
    character(len=:), allocatable, intent(inout) :: seen  !< ' group group ... '
    integer :: k, e
    logical :: quoted
    character :: q

    quoted = .false.
    q = ' '
    do k = 1, len_trim(text)
      if (quoted) then
        if (text(k:k) == q) quoted = .false.
      else if (text(k:k) == '''' .or. text(k:k) == '"') then
        quoted = .true.
        q = text(k:k)
      else if (text(k:k) == '&') then
        e = k + 1
        do while (e <= len_trim(text))
          if (verify(text(e:e), 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ_0123456789') /= 0) exit
          e = e + 1
        end do
        if (index(GROUPS, ' '//to_lower(text(k + 1:e - 1))//' ') == 0) then
          c%status = MLID_ERR_INPUT
          c%msg = 'line '//itoa(line)//': unknown group &'//text(k + 1:e - 1)// &
                  ' (groups are &case, &model, &data, &simulate, &estimate)'
          return
        end if
        ! a compiler's namelist read would take the first and ignore the rest
        if (index(seen, ' '//to_lower(text(k + 1:e - 1))//' ') > 0) then
          c%status = MLID_ERR_INPUT
          c%msg = 'line '//itoa(line)//': group &'//text(k + 1:e - 1)//' given twice in one case'
          return
        end if
        seen = seen//to_lower(text(k + 1:e - 1))//' '
      end if
    end do
  end subroutine check_groups

  !> Index into theta of a parameter named key(i) or key(i,j) after the
  !> block table (keys, rows, columns, offsets); 0 if there is no such element.
  subroutine element_index(name, bkey, brow, bcol, boff, idx)
    character(len=*), intent(in) :: name, bkey(:)
    integer, intent(in) :: brow(:), bcol(:), boff(:)
    integer, intent(out) :: idx
    integer :: p, q, i, j, ios, b
    character(len=len(name)) :: s

    idx = 0
    s = to_lower(adjustl(name))
    p = index(s, '(')
    q = index(s, ')')
    if (p < 2 .or. q < p + 2 .or. len_trim(s) /= q) return
    j = 0
    if (index(s(p + 1:q - 1), ',') > 0) then
      read (s(p + 1:q - 1), *, iostat=ios) i, j
    else
      read (s(p + 1:q - 1), *, iostat=ios) i
    end if
    if (ios /= 0) return
    do b = 1, size(bkey)
      if (trim(bkey(b)) /= trim(s(1:p - 1)) .or. len_trim(bkey(b)) == 0) cycle
      if (i < 1 .or. i > brow(b)) return
      if (bcol(b) < 0) then
        if (j == 0) idx = boff(b) + i
      else if (j >= 1 .and. j <= bcol(b)) then
        idx = boff(b) + (j - 1)*brow(b) + i
      end if
      return
    end do
  end subroutine element_index

  !> The record of an estimate case: time, inputs and outputs from its
  !> data files (paths resolved by the reader).  Several files are
  !> several manoeuvres, one after the other, each keeping its sampling with
  !> its times moved to follow the one before; segstart(k) is the first
  !> sample of manoeuvre k.
  subroutine case_record(c, t, u, y, status, msg, segstart)
    type(case_t), intent(in) :: c
    real(wp), allocatable, intent(out) :: t(:), u(:, :), y(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, allocatable, intent(out), optional :: segstart(:)
    real(wp), allocatable :: tk(:), uk(:, :), yk(:, :)
    integer :: k, nseg
    integer :: starts(MAXSEG)

    nseg = size(c%data_files)
    allocate (t(0), u(c%nu, 0), y(c%ny, 0))
    do k = 1, nseg
      call read_record(c, c%data_files(k), tk, uk, yk, status, msg)
      if (status /= MLID_OK) return
      if (size(tk) < 2 .and. nseg > 1) then
        status = MLID_ERR_INPUT
        write (msg, '(a,i0,a)') 'manoeuvre ', k, ' ('//trim(c%data_files(k))// &
          ') has fewer than 2 samples'
        return
      end if
      starts(k) = size(t) + 1
      if (k > 1) tk = tk - tk(1) + t(size(t)) + (tk(2) - tk(1))
      t = [t, tk]
      u = reshape([u, uk], [c%nu, size(t)])
      y = reshape([y, yk], [c%ny, size(t)])
    end do
    if (present(segstart)) segstart = starts(1:nseg)
  end subroutine case_record

  !> One data file: the case's columns of it.
  subroutine read_record(c, path, t, u, y, status, msg)
    type(case_t), intent(in) :: c
    character(len=*), intent(in) :: path
    real(wp), allocatable, intent(out) :: t(:), u(:, :), y(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=LINELEN), allocatable :: lines(:)
    real(wp), allocatable :: table(:, :), row(:)
    integer :: k, n, ncol, ios, nrow

    call read_lines(path, lines, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    n = size(lines)
    allocate (table(0, 0))
    ncol = 0
    nrow = 0
    do k = c%skip_rows + 1, n
      if (len_trim(strip_comment(lines(k), '#')) == 0) cycle
      if (ncol == 0) then
        ncol = count_fields(lines(k))
        deallocate (table)
        allocate (table(ncol, n), row(ncol))
      end if
      if (count_fields(lines(k)) /= ncol) then
        write (msg, '(a,i0,a,i0,a,i0)') 'data file '//trim(path)//' line ', k, ': ', &
          count_fields(lines(k)), ' columns, expected ', ncol
        return
      end if
      read (lines(k), *, iostat=ios) row
      if (ios /= 0) then
        write (msg, '(a,i0,a)') 'data file '//trim(path)//' line ', k, ': malformed number'
        return
      end if
      nrow = nrow + 1
      table(:, nrow) = row
    end do
    if (nrow == 0) then
      msg = 'data file '//trim(path)//': no data rows'
      return
    end if
    if (maxval([c%input_cols, c%output_cols, c%time_col]) > ncol) then
      write (msg, '(a,i0,a,i0,a)') 'data file '//trim(path)//': column ', &
        maxval([c%input_cols, c%output_cols, c%time_col]), ' requested, the file has ', ncol, &
        ' columns'
      return
    end if
    t = table(c%time_col, 1:nrow)
    u = table(c%input_cols, 1:nrow)
    y = table(c%output_cols, 1:nrow)
    status = MLID_OK
    msg = ''
  end subroutine read_record

  !> The case's parameters for nseg manoeuvres: every manoeuvre its own
  !> initial state and biases (the x0 and bias blocks repeated, start values
  !> and free flags alike), the rest shared; labels of a manoeuvre's own
  !> entries end in '#k'.  As mlid/maneuvers.py does for Python.
  subroutine manoeuvre_layout(c, nseg, status, msg)
    type(case_t), intent(inout) :: c
    integer, intent(in) :: nseg
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: nth, np, nx, ny, own, k, j, shift
    integer, allocatable :: map(:), seg(:)
    character(len=NAMELEN), allocatable :: full(:), lab(:)
    character(len=8) :: suffix

    status = MLID_OK
    msg = ''
    if (nseg <= 1) return
    nx = c%nx
    ny = c%ny
    nth = size(c%theta)
    np = nth - (nx + ny + c%nw + ny + c%nw*ny)
    own = nx + ny
    if (any(c%itie /= 0 .and. ((c%itie > np .and. c%itie <= np + own) .or. &
                               [(k > np .and. k <= np + own, k=1, nth)]))) then
      status = MLID_ERR_INPUT
      msg = 'ties to or from initial states and biases are not available with several manoeuvres'
      return
    end if
    ! map(k): the single-manoeuvre entry that entry k of the new vector copies; seg(k) its manoeuvre
    allocate (map(0), seg(0))
    map = [(k, k=1, np)]
    seg = [(0, k=1, np)]
    do j = 1, nseg
      map = [map, (np + k, k=1, nx)]
      seg = [seg, (j, k=1, nx)]
    end do
    do j = 1, nseg
      map = [map, (np + nx + k, k=1, ny)]
      seg = [seg, (j, k=1, ny)]
    end do
    map = [map, (k, k=np + own + 1, nth)]
    seg = [seg, (0, k=np + own + 1, nth)]
    allocate (full(nth))
    full = ''
    full(pack([(k, k=1, nth)], c%isfree == 1)) = c%labels
    if (c%use_prior == 1) then
      if (any(c%isfree(np + 1:np + own) == 1)) then
        status = MLID_ERR_INPUT
        msg = 'a priori weighting with free initial states or biases is not available with '// &
              'several manoeuvres'
        return
      end if
    end if
    allocate (lab(size(map)))
    do k = 1, size(map)
      lab(k) = full(map(k))
      if (seg(k) > 0) then
        write (suffix, '(a,i0)') '#', seg(k)
        lab(k) = trim(full(map(k)))//trim(suffix)
      end if
    end do
    shift = (nseg - 1)*own
    c%itie = merge(c%itie + shift, c%itie, c%itie > np + own)
    c%itie = c%itie(map)
    c%theta = c%theta(map)
    if (allocated(c%prior)) c%prior = c%prior(map)
    if (allocated(c%lower)) c%lower = c%lower(map)
    if (allocated(c%upper)) c%upper = c%upper(map)
    if (allocated(c%pweight)) call grow_weight()
    c%isfree = c%isfree(map)
    c%labels = pack(lab, c%isfree == 1)

  contains

    !> The a priori weight over the new free set: shared entries keep
    !> theirs, a manoeuvre's own get none (none had one, checked above).
    subroutine grow_weight()
      real(wp), allocatable :: w(:, :)
      integer, allocatable :: old(:), newf(:)
      integer :: a, b, ia, ib
      old = pack([(k, k=1, nth)], c%isfree == 1)
      newf = pack([(k, k=1, size(map))], c%isfree(map) == 1)
      allocate (w(size(newf), size(newf)))
      w = 0.0_wp
      do a = 1, size(newf)
        if (seg(newf(a)) > 0) cycle
        ia = findloc(old, map(newf(a)), 1)
        do b = 1, size(newf)
          if (seg(newf(b)) > 0) cycle
          ib = findloc(old, map(newf(b)), 1)
          w(a, b) = c%pweight(ia, ib)
        end do
      end do
      c%pweight = w
    end subroutine grow_weight

  end subroutine manoeuvre_layout

  !> Time base t = 0, dt, ..., and inputs of a simulate case.
  subroutine case_time_input(c, t, u, status, msg)
    type(case_t), intent(in) :: c
    real(wp), allocatable, intent(out) :: t(:), u(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: nt, k

    nt = nint(c%t_end/c%dt) + 1
    t = [(real(k - 1, wp)*c%dt, k=1, nt)]
    allocate (u(c%nu, nt))
    status = MLID_OK
    msg = ''
    do k = 1, c%nu
      call input_signal(c%input_shape(k), c%amplitude(k), c%t_start(k), c%pulse_width(k), c%dt, &
                        u(k, :), status, msg)
      if (status /= MLID_OK) return
    end do
  end subroutine case_time_input

  !> Path relative to the deck's folder unless absolute.
  function resolve(dir, file) result(path)
    character(len=*), intent(in) :: dir, file
    character(len=PATHLEN) :: path
    if (file(1:1) == '/' .or. len_trim(dir) == 0) then
      path = file
    else
      path = trim(dir)//'/'//trim(file)
    end if
  end function resolve

  subroutine read_lines(path, lines, status, msg)
    character(len=*), intent(in) :: path
    character(len=LINELEN), allocatable, intent(out) :: lines(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=LINELEN) :: buf
    integer :: unit, ios, n
    logical :: exists

    allocate (lines(0))
    inquire (file=path, exist=exists)
    if (.not. exists) then
      status = MLID_ERR_INPUT
      msg = 'file not found: '//trim(path)
      return
    end if
    open (newunit=unit, file=path, status='old', action='read', iostat=ios)
    if (ios /= 0) then
      status = MLID_ERR_INPUT
      msg = 'cannot open '//trim(path)
      return
    end if
    n = 0
    do
      read (unit, '(a)', iostat=ios) buf
      if (ios /= 0) exit
      n = n + 1
      if (n > size(lines)) lines = [character(len=LINELEN) :: lines, (' ', ios=1, max(64, n))]
      lines(n) = buf
    end do
    close (unit)
    lines = lines(1:n)
    status = MLID_OK
    msg = ''
  end subroutine read_lines

  !> The line without its comment (from the first mark outside quotes).
  function strip_comment(line, mark) result(s)
    character(len=*), intent(in) :: line
    character, intent(in), optional :: mark
    character(len=len(line)) :: s
    character :: q, cm
    logical :: quoted
    integer :: k
    cm = '!'
    if (present(mark)) cm = mark
    s = line
    quoted = .false.
    q = ' '
    do k = 1, len_trim(line)
      if (quoted) then
        if (line(k:k) == q) quoted = .false.
      else if (line(k:k) == '''' .or. line(k:k) == '"') then
        quoted = .true.
        q = line(k:k)
      else if (line(k:k) == cm) then
        s = line(1:k - 1)
        return
      end if
    end do
  end function strip_comment

  function first_word(line) result(w)
    character(len=*), intent(in) :: line
    character(len=16) :: w
    character(len=len(line)) :: s
    integer :: e
    s = adjustl(line)
    e = scan(s, ' /,'//achar(9))
    if (e == 0) e = len(s) + 1
    w = to_lower(s(1:min(e - 1, 16)))
  end function first_word

  !> Line number of the first &group in the case (for messages).
  integer function group_line(lines, line0, group)
    character(len=*), intent(in) :: lines(:), group
    integer, intent(in) :: line0
    integer :: k
    group_line = line0
    do k = 1, size(lines)
      if (index(to_lower(strip_comment(lines(k))), '&'//group) > 0) then
        group_line = line0 + k - 1
        return
      end if
    end do
  end function group_line

  integer function count_fields(line)
    character(len=*), intent(in) :: line
    integer :: k
    logical :: inside
    count_fields = 0
    inside = .false.
    do k = 1, len_trim(line)
      if (index(' ,'//achar(9), line(k:k)) > 0) then
        inside = .false.
      else if (.not. inside) then
        inside = .true.
        count_fields = count_fields + 1
      end if
    end do
  end function count_fields

  pure function to_lower(s) result(r)
    character(len=*), intent(in) :: s
    character(len=len(s)) :: r
    integer :: k
    r = s
    do k = 1, len(s)
      if (s(k:k) >= 'A' .and. s(k:k) <= 'Z') r(k:k) = achar(iachar(s(k:k)) + 32)
    end do
  end function to_lower

  function itoa(i) result(s)
    integer, intent(in) :: i
    character(len=:), allocatable :: s
    character(len=16) :: buf
    write (buf, '(i0)') i
    s = trim(buf)
  end function itoa

end module mlid_deck
