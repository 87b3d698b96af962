!> Batch decks: Fortran namelist groups, several cases stacked in one file.
!>
!> A case starts at each line whose first word is &case and holds the groups
!>   &case     title, job ('estimate', 'validate', 'simulate', 'design' or
!>             'monte_carlo'); the flight condition for campaign tables: mach,
!>             altitude, alpha_trim, config, tags
!>   &model    kind ('linear', 'longitudinal', 'x22', 'user' or 'equations'), nx, nu,
!>             ny, nw, f, g, h, d, gamma (row by row), cd_regressors, cl_regressors,
!>             cm_regressors, cd, cl, cm, constants (longitudinal), p,
!>             user_iconst, user_rconst (user), xdot, outputs, definitions,
!>             params (equations), x0, bias, q, r, s (noise
!>             variances, cross-covariance row by row), free, names, tie,
!>             input_hold, substeps, state_names, input_names, output_names,
!>             initial_states (nx per manoeuvre, manoeuvre after manoeuvre),
!>             delay (each output's time delay, s)
!>   &data     file, time_col, input_cols, output_cols (numbers or names),
!>             skip_rows, columns, units, derived, t_start, t_end,
!>             holdout (validate: the files predicted, not fitted), dt (a uniform
!>             time step replacing the record's time), join, join_columns (files
!>             whose columns extend the records' rows)              (estimate, validate)
!>   &simulate out, t_end, dt, seed, noise_std, input_shape, amplitude,
!>             t_start, pulse_width, input_file (a record's time and inputs
!>             instead of t_end, dt and a shape)                     (simulate)
!>   &design   unknowns (elements of F, G, H; default the free ones), t_end,
!>             dt, energy (operator, riccati, equalised) or peak and
!>             min_width (amplitude), weights, servo (time constant per
!>             input), process_noise (Gamma Q Gamma'), method, iterations,
!>             out (the record of t and the inputs)                  (design)
!>   &monte_carlo runs, seed, truth (per free parameter), input_file;
!>             &estimate's options for the fits                 (monte_carlo)
!>   &estimate method, startup, max_iter, halvings, noise, partials, steady_state,
!>             process_noise, noise_criterion, filter_params, tol_cost, tol_step, tol_grad, rcond,
!>             prior, prior_weight,
!>             prior_decay, rank_min, rank_max, rank_rule, lower, upper (per free parameter, in the
!>             order of free), corrected (kind flight_path: one record per data file),
!>             f_min, f_max, n_freq (the band of the frequency-domain methods, Hz)
!> A problem in one case is kept in that case (status, msg) and the others
!> are still read.  Python reads decks through this reader too (mlid_api's
!> mlid_deck_* routines; python/mlid/deck.py).
!>
!> This file holds the interface (the public names, the constants, reader_t,
!> and the interfaces of the submodules' procedures that other files call),
!> deck_read and the case-level driver (read_case, resolve_paths), and the
!> readers of &case, &simulate, &design, &monte_carlo.  Its submodules:
!> mlid_deck_model (&model), mlid_deck_equations (the &model kinds written
!> as equations), mlid_deck_data (&data), mlid_deck_estimate (&estimate);
!> mlid_deck_reader (what the group readers share); mlid_deck_record (what
!> the front ends ask of a case once read: its record, its manoeuvres'
!> layout).
module mlid_deck
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, msg_len, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: to_lower, itoa, read_text, line_t
  use mlid_deck_scan, only: deck_scan, assignment_t
  use mlid_files, only: same_file
  use mlid_case, only: case_t, NAMELEN, PATHLEN, MAX_SAMPLES, NCONDITION, CONDITION_NAMES
  use mlid_model_factory, only: MODEL_LINEAR
  use mlid_options, only: options_t, options_to_flat, options_from_flat
  use mlid_units, only: UNITLEN
  use mlid_layout, only: layout_table_t, layout_of, element_index, element_name, locate
  implicit none
  private
  public :: case_t, deck_read, deck_open, case_record, case_time_input, manoeuvre_layout, &
            case_param_units, holdout_case, manoeuvre_block, corrected_writable, NAMELEN, &
            PATHLEN

  !> The cases of the deck last opened by deck_open, for the flat interface.
  type(case_t), allocatable, protected, public :: opened(:)

  integer, parameter :: MAXX = 30, MAXU = 30, MAXY = 30, MAXW = 10, MAXFREE = 200, MAXCOL = 100
  integer, parameter :: MAXR = 12   !< regressors of each coefficient
  integer, parameter :: MAXDER = 50, CHANLEN = 64, EXPRLEN = 1024  !< &data entries
  integer, parameter :: TIELEN = 512                                !< a tie's or equation's text
  integer, parameter :: MAXDEF = 100                                !< an equations model's definitions
  real(wp), parameter :: UNSET = huge(1.0_wp)   !< marks array entries the deck did not give
  character(len=*), parameter :: GROUP_NAMES = ' case model data simulate estimate design monte_carlo '
  !> The jobs of &case, and the methods of &design
  character(len=12), parameter :: JOBS(5) = [character(len=12) :: 'estimate', 'validate', &
                                             'simulate', 'design', 'monte_carlo']
  character(len=10), parameter :: DESIGN_METHODS(4) = [character(len=10) :: 'operator', &
                                                       'riccati', 'amplitude', 'equalised']

  !> What the group readers of one case share: the scratch unit with the
  !> case's text and its lines (for line numbers in messages).
  type :: reader_t
    integer :: unit = 0, line0 = 0
    type(line_t), allocatable :: lines(:)
    type(assignment_t), allocatable :: given(:)   !< the case's assignments (deck_scan)
  end type reader_t

  interface

    ! in mlid_deck_reader

    !> A missing group or a namelist read error, as the case's message.
    module subroutine group_status(rd, group, ios, iomsg, required, c)
      type(reader_t), intent(in) :: rd
      character(len=*), intent(in) :: group, iomsg
      integer, intent(in) :: ios
      logical, intent(in) :: required
      type(case_t), intent(inout) :: c
    end subroutine group_status

    !> Whether quoted text given to one of keys is longer than room (the case fails).
    module logical function too_long(rd, c, group, keys, room)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
      character(len=*), intent(in) :: group, keys(:)
      integer, intent(in) :: room
    end function too_long

    !> The case fails (MLID_ERR_INPUT) with message text.
    module subroutine fail(c, text)
      type(case_t), intent(inout) :: c
      character(len=*), intent(in) :: text
    end subroutine fail

    !> Set an option of the case by name from the deck's text.
    module subroutine set_option(c, where, name, text)
      type(case_t), intent(inout) :: c
      character(len=*), intent(in) :: where, name, text
    end subroutine set_option

    !> 'a', 'b' or 'c': a list of choices for a message.
    module function choices(list) result(text)
      character(len=*), intent(in) :: list(:)
      character(len=:), allocatable :: text
    end function choices

    !> The line without its comment.
    module function strip_comment(line) result(s)
      character(len=*), intent(in) :: line
      character(len=len(line)) :: s
    end function strip_comment

    ! in mlid_deck_model

    !> &model: kind and sizes, parameters, free ones and labels, ties, names.
    module subroutine read_model_group(rd, c, free_idx)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
      integer, allocatable, intent(out) :: free_idx(:)
    end subroutine read_model_group

    ! in mlid_deck_equations

    !> An equations model's text from the deck.
    module subroutine equations_text(c, states, xdot, inputs, ynames, outputs, definitions, &
                                     params, pstart, pre, post)
      type(case_t), intent(inout) :: c
      character(len=*), intent(in) :: states(:), xdot(:), inputs(:), ynames(:), outputs(:), &
                                      definitions(:), params(:)
      real(wp), allocatable, intent(out) :: pstart(:)
      character(len=*), intent(in), optional :: pre, post   !< lines around the definitions (sixdof)
    end subroutine equations_text

    !> kind = 'sixdof': the rigid-body lines around the deck's definitions.
    module subroutine sixdof_deck(c, constants, states, xdot, inputs, definitions, pre, post, xs)
      type(case_t), intent(inout) :: c
      real(wp), intent(in) :: constants(:)
      character(len=*), intent(in) :: states(:), xdot(:), inputs(:), definitions(:)
      character(len=:), allocatable, intent(out) :: pre, post
      character(len=TIELEN), allocatable, intent(out) :: xs(:)
    end subroutine sixdof_deck

    !> The kinds whose model is a text of equations.
    module logical function written_as_equations(kind)
      character(len=*), intent(in) :: kind
    end function written_as_equations

    !> kind = 'flight_path': the kinematic model with its corrections.
    module subroutine flightpath_deck(c, constants, states, xdot, inputs, ynames, outputs, &
                                      definitions, params, pstart)
      type(case_t), intent(inout) :: c
      real(wp), intent(in) :: constants(:)
      character(len=*), intent(in) :: states(:), xdot(:), outputs(:), definitions(:), params(:)
      character(len=*), intent(inout) :: inputs(:), ynames(:)
      real(wp), allocatable, intent(out) :: pstart(:)
    end subroutine flightpath_deck

    ! in mlid_deck_data

    !> &data: the records, their channels and windows.
    module subroutine read_data_group(rd, c)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
    end subroutine read_data_group

    !> initial_states: nx values for each data file.
    module subroutine check_initial_states(c)
      type(case_t), intent(inout) :: c
    end subroutine check_initial_states

    ! in mlid_deck_estimate

    !> &estimate: the estimator's options, prior and bounds.
    module subroutine read_estimate_group(rd, c, free_idx)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
      integer, intent(in) :: free_idx(:)
    end subroutine read_estimate_group

    ! in mlid_deck_record

    !> The entries of theta's block key that hold for manoeuvre j.
    module function manoeuvre_block(c, nseg, theta, j, key) result(v)
      type(case_t), intent(in) :: c
      integer, intent(in) :: nseg, j
      real(wp), intent(in) :: theta(:)
      character(len=*), intent(in) :: key
      real(wp), allocatable :: v(:)
    end function manoeuvre_block

    !> Whether every corrected record's path can be written.
    module subroutine corrected_writable(c, status, msg)
      type(case_t), intent(in) :: c
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
    end subroutine corrected_writable

    !> The record of an estimate case: time, inputs and outputs from its data files.
    module subroutine case_record(c, t, u, y, status, msg, segstart, units, names, notes, own_t)
      type(case_t), intent(in) :: c
      real(wp), allocatable, intent(out) :: t(:), u(:, :), y(:, :)
      !> each manoeuvre's time as its file gives it (t moves them one after another)
      real(wp), allocatable, intent(out), optional :: own_t(:)
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
      integer, allocatable, intent(out), optional :: segstart(:)
      character(len=UNITLEN), allocatable, intent(out), optional :: units(:)  !< inputs, outputs
      character(len=NAMELEN), allocatable, intent(out), optional :: names(:)  !< the channels'
      type(line_t), allocatable, intent(out), optional :: notes(:)
    end subroutine case_record

    !> The case's parameters for nseg manoeuvres.
    module subroutine manoeuvre_layout(c, nseg, status, msg)
      type(case_t), intent(inout) :: c
      integer, intent(in) :: nseg
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
    end subroutine manoeuvre_layout

    !> The units of the case's free parameters on nseg manoeuvres.
    module subroutine case_param_units(c, nseg, channel_units, units, status, msg)
      type(case_t), intent(in) :: c
      integer, intent(in) :: nseg
      character(len=*), intent(in) :: channel_units(:)
      character(len=UNITLEN), allocatable, intent(out) :: units(:)
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
    end subroutine case_param_units

    !> The case that predicts the held-out manoeuvres of a validate case.
    module subroutine holdout_case(c, theta_fit, nfit, h, status, msg)
      type(case_t), intent(in) :: c
      real(wp), intent(in) :: theta_fit(:)
      integer, intent(in) :: nfit
      type(case_t), intent(out) :: h
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
    end subroutine holdout_case

    !> Time base and inputs of a simulate (or monte_carlo) case.
    module subroutine case_time_input(c, t, u, status, msg)
      type(case_t), intent(in) :: c
      real(wp), allocatable, intent(out) :: t(:), u(:, :)
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
    end subroutine case_time_input

  end interface

contains

  !> Read every case of a deck.  status /= 0 only when the deck as a whole
  !> cannot be used (missing file, no &case); per-case problems are kept in
  !> the cases.
  subroutine deck_read(path, cases, status, msg)
    character(len=*), intent(in) :: path
    type(case_t), allocatable, intent(out) :: cases(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(line_t), allocatable :: lines(:)
    integer, allocatable :: starts(:)
    integer :: n, k, last

    allocate (cases(0))
    call read_text(path, lines, status, msg)
    if (status /= MLID_OK) return
    n = size(lines)
    allocate (starts(0))
    do k = 1, n
      if (first_word(lines(k)%s) == '&case') starts = [starts, k]
    end do
    if (size(starts) == 0) then
      status = MLID_ERR_INPUT
      msg = trim(path)//': no &case group found (a deck is a sequence of cases, each starting with &case)'
      return
    end if
    do k = 1, starts(1) - 1
      if (len_trim(strip_comment(lines(k)%s)) > 0) then
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

  !> File names of a case are taken from the deck's folder unless absolute;
  !> a record the case writes may not be the deck or a file it reads.
  subroutine resolve_paths(deck, c)
    character(len=*), intent(in) :: deck
    type(case_t), intent(inout) :: c
    character(len=:), allocatable :: dir
    integer :: k
    dir = ''
    if (index(deck, '/', back=.true.) > 0) dir = deck(1:index(deck, '/', back=.true.) - 1)
    if (allocated(c%data_files)) then
      do k = 1, size(c%data_files)
        call resolve_into(c, dir, c%data_files(k))
      end do
    end if
    if (len_trim(c%out_file) > 0) call resolve_into(c, dir, c%out_file)
    if (len_trim(c%input_file) > 0) call resolve_into(c, dir, c%input_file)
    if (c%status == MLID_OK .and. len_trim(c%out_file) > 0) then
      if (read_by_case(deck, c, c%out_file)) &
        call fail(c, 'group &'//trim(c%job)//': out '''//trim(c%out_file)//''' is the deck '// &
                  'or the input_file: the record written would overwrite what it is made from')
    end if
    if (allocated(c%corrected)) then
      do k = 1, size(c%corrected)
        call resolve_into(c, dir, c%corrected(k))
      end do
      do k = 1, size(c%corrected)   ! the names as resolved from the deck's folder
        if (c%status == MLID_OK .and. (count(c%corrected == c%corrected(k)) > 1 .or. &
            read_by_case(deck, c, c%corrected(k)))) &
          call fail(c, 'group &estimate: corrected names '''//trim(c%corrected(k))// &
                    ''' twice, or a data file: each record goes to a file of its own, not one the '// &
                    'case reads or the deck')
      end do
    end if
    if (allocated(c%chan%join)) then
      do k = 1, size(c%chan%join)
        if (len(c%chan%join(k)%s) >= PATHLEN) call path_too_long(c, c%chan%join(k)%s)
        c%chan%join(k)%s = resolve(dir, c%chan%join(k)%s)
      end do
      do k = 1, size(c%chan%files)
        c%chan%files(k)%s = resolve(dir, c%chan%files(k)%s)
      end do
    end if
  end subroutine resolve_paths

  !> A file name of the deck resolved from its folder (dir), or the case's
  !> message when it does not fit (or may have been cut on reading).
  subroutine resolve_into(c, dir, path)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: dir
    character(len=*), intent(inout) :: path
    character(len=:), allocatable :: full
    full = resolve(dir, path)
    if (len_trim(path) == len(path) .or. len(full) >= len(path)) then
      call path_too_long(c, full)
    else
      path = full
    end if
  end subroutine resolve_into

  subroutine path_too_long(c, path)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: path
    if (c%status == MLID_OK) call fail(c, 'file name '''//path(1:min(len(path), 40))// &
      '...'' is longer than '//itoa(PATHLEN - 1)//' characters (with the deck''s folder)')
  end subroutine path_too_long

  !> Whether path is the deck, the case's input_file or one of its data
  !> files (the same file, however named).
  logical function read_by_case(deck, c, path)
    character(len=*), intent(in) :: deck, path
    type(case_t), intent(in) :: c
    integer :: k
    read_by_case = same_file(path, deck) .or. same_file(path, c%input_file)
    if (.not. allocated(c%data_files)) return
    do k = 1, size(c%data_files)
      read_by_case = read_by_case .or. same_file(path, c%data_files(k))
    end do
  end function read_by_case

  !> Parse one case from its lines (first is the &case line, number line0):
  !> one reader per group, each after the one before succeeded.
  subroutine read_case(lines, line0, c)
    type(line_t), intent(in) :: lines(:)
    integer, intent(in) :: line0
    type(case_t), intent(inout) :: c
    type(reader_t) :: rd
    type(case_t) :: scanned
    type(options_t) :: opt
    integer, allocatable :: free_idx(:)
    type(line_t), allocatable :: stripped(:)
    character(len=msg_len) :: msg
    integer :: k, status

    ! The case without comments goes to a scratch file that each group's
    ! namelist read rewinds: gfortran and a Python reader disagree on
    ! comments after a trailing comma.  deck_scan first checks the text as a
    ! whole (what a namelist read would pass over or take silently), and
    ! keeps its assignments for blame.
    rd%line0 = line0
    rd%lines = lines
    open (newunit=rd%unit, status='scratch', action='readwrite', form='formatted')
    allocate (stripped(size(lines)))
    do k = 1, size(lines)
      stripped(k)%s = trim(strip_comment(lines(k)%s))
      write (rd%unit, '(a)') stripped(k)%s
    end do
    call deck_scan(stripped, line0, GROUP_NAMES, status, msg, rd%given)
    if (status /= MLID_OK) call fail(c, msg)
    call options_to_flat(options_t(), c%iopt, c%ropt)
    ! the title first, so that a message about the groups names the case
    scanned = c
    c%status = MLID_OK
    call read_case_group(rd, c)
    if (scanned%status /= MLID_OK) then
      c%status = scanned%status
      c%msg = scanned%msg
    end if
    if (c%status == MLID_OK) call read_model_group(rd, c, free_idx)
    if (c%status == MLID_OK .and. any(c%job == ['estimate', 'validate'])) then
      call read_data_group(rd, c)
      if (c%status == MLID_OK) call check_initial_states(c)
      if (c%status == MLID_OK) call read_estimate_group(rd, c, free_idx)
    else if (c%status == MLID_OK) then
      if (size(c%initial_states) > 0) &
        call fail(c, 'group &model: initial_states is for estimate cases (several data files)')
      if (c%status == MLID_OK .and. c%job == 'simulate') call read_simulate_group(rd, c)
      if (c%status == MLID_OK .and. c%job == 'design') call read_design_group(rd, c)
      if (c%status == MLID_OK .and. c%job == 'monte_carlo') then
        call read_monte_carlo_group(rd, c, free_idx)
        if (c%status == MLID_OK) call read_estimate_group(rd, c, free_idx)
        if (c%status == MLID_OK .and. (c%use_prior == 1 .or. c%use_bounds == 1 .or. &
            allocated(c%corrected))) call fail(c, 'group &estimate: prior, bounds and '// &
            'corrected are not used by job ''monte_carlo'' (each run starts from &model)')
      end if
    end if
    if (c%status == MLID_OK) then
      call options_from_flat(c%iopt, c%ropt, opt, c%status, c%msg)
    end if
    close (rd%unit)
  end subroutine read_case

  !> &case: title, job and the flight condition (mach, altitude, alpha_trim,
  !> config, tags: for campaign tables; not given is not zero).
  subroutine read_case_group(rd, c)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    character(len=256) :: title             !< longer than the case's, to see a title too long
    character(len=16) :: job
    character(len=1024) :: config, tags     !< longer than the case's too
    real(wp) :: mach, altitude, alpha_trim, given(NCONDITION)
    character(len=msg_len) :: iomsg
    integer :: ios, i
    namelist /case/ title, job, mach, altitude, alpha_trim, config, tags

    title = ''
    job = ''
    config = ''
    tags = ''
    mach = huge(1.0_wp)
    altitude = huge(1.0_wp)
    alpha_trim = huge(1.0_wp)
    rewind (rd%unit)
    read (rd%unit, nml=case, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'case', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    c%title = title
    c%job = to_lower(job)
    if (len_trim(title) > len(c%title)) then
      call fail(c, 'group &case: title is longer than '//itoa(len(c%title))//' characters')
      return
    end if
    if (len_trim(config) > len(c%config) .or. len_trim(tags) > len(c%tags)) then
      call fail(c, 'group &case: config is longer than '//itoa(len(c%config))//' characters, '// &
                'or tags than '//itoa(len(c%tags)))
      return
    end if
    c%config = config
    c%tags = tags
    given = [mach, altitude, alpha_trim]
    do i = 1, NCONDITION
      if (given(i) == huge(1.0_wp)) cycle
      if (.not. ieee_is_finite(given(i))) then
        call fail(c, 'group &case: '//trim(CONDITION_NAMES(i))//' is not a finite number')
        return
      end if
      c%condition(i) = given(i)
      c%condition_given(i) = .true.
    end do
    if (c%condition_given(1) .and. c%condition(1) < 0.0_wp) then
      call fail(c, 'group &case: mach must be >= 0')
      return
    end if
    if (all(c%job /= JOBS)) &
      call fail(c, 'group &case: job must be '//choices(JOBS)//', got '''//trim(job)//'''')
  end subroutine read_case_group

  !> &simulate: the record to write, its time base, inputs and noise.
  subroutine read_simulate_group(rd, c)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    character(len=PATHLEN) :: out
    character(len=16) :: input_shape(MAXU)
    real(wp) :: t_end, dt, noise_std(MAXY), amplitude(MAXU), t_start(MAXU), pulse_width(MAXU)
    integer :: seed, ios, o
    type(layout_table_t) :: lt
    character(len=msg_len) :: iomsg
    character(len=PATHLEN) :: input_file
    namelist /simulate/ out, t_end, dt, seed, noise_std, input_shape, amplitude, t_start, &
      pulse_width, input_file

    out = ''
    t_end = 0.0_wp
    dt = 0.0_wp
    seed = 0
    noise_std = UNSET
    input_shape = ''
    amplitude = UNSET
    t_start = UNSET
    pulse_width = UNSET
    input_file = ''
    rewind (rd%unit)
    read (rd%unit, nml=simulate, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'simulate', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    c%out_file = out
    c%input_file = input_file
    c%t_end = t_end
    c%dt = dt
    c%seed = seed
    if (len_trim(input_file) > 0 .and. (t_end /= 0.0_wp .or. dt /= 0.0_wp .or. &
        any(len_trim(input_shape) > 0) .or. any(amplitude /= UNSET) .or. &
        any(t_start /= UNSET) .or. any(pulse_width /= UNSET))) then
      call fail(c, 'group &simulate: input_file gives the time and inputs; t_end, dt, '// &
                'input_shape, amplitude, t_start and pulse_width are for a standard input')
      return
    end if
    ! one value serves every input; otherwise one per input
    c%input_shape = per_input_text(input_shape, c%nu, 'none')
    c%t_start = per_input(t_start, c%nu)
    c%pulse_width = per_input(pulse_width, c%nu)
    c%noise_std = pack(noise_std, noise_std /= UNSET)
    c%amplitude = pack(amplitude, amplitude /= UNSET)
    if (size(c%amplitude) == 0) c%amplitude = spread(0.0_wp, 1, c%nu)
    call check_simulate(c)
    if (c%status /= MLID_OK) return
    ! noise_std, when given, sets the measurement-noise variances r
    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, ios, iomsg)
    if (ios /= MLID_OK) then
      call fail(c, 'group &simulate: '//trim(iomsg))
      return
    end if
    o = lt%off(findloc(lt%key, 'r', 1))
    if (size(c%noise_std) == c%ny) c%theta(o + 1:o + c%ny) = c%noise_std**2
  end subroutine read_simulate_group

  subroutine check_simulate(c)
    type(case_t), intent(inout) :: c
    character(len=msg_len) :: iomsg
    if (len_trim(c%out_file) == 0) then
      call fail(c, 'group &simulate: out (the data file to write) is missing')
    else if (len_trim(c%input_file) == 0 .and. .not. (c%dt > 0.0_wp .and. c%t_end > c%dt)) then
      call fail(c, 'group &simulate: need dt > 0 and t_end > dt')
    else if (len_trim(c%input_file) == 0 .and. .not. (c%t_end/c%dt < real(MAX_SAMPLES, wp))) then
      write (iomsg, '(a,es10.3,a,i0,a)') 'group &simulate: t_end/dt =', c%t_end/c%dt, &
        ' samples; at most ', MAX_SAMPLES, ' are allowed'
      call fail(c, iomsg)
    else if (size(c%noise_std) /= c%ny .and. size(c%noise_std) /= 0) then
      write (iomsg, '(a,i0,a,i0,a)') 'group &simulate: noise_std has ', size(c%noise_std), &
        ' values, the model has ', c%ny, ' outputs'
      call fail(c, iomsg)
    else if (.not. all(c%noise_std >= 0.0_wp .and. c%noise_std < UNSET)) then
      call fail(c, 'group &simulate: noise_std (the standard deviation of each output''s '// &
                'noise) must be >= 0 and finite')
    else if (size(c%amplitude) /= c%nu) then
      write (iomsg, '(a,i0,a,i0,a)') 'group &simulate: amplitude has ', size(c%amplitude), &
        ' values, the model has ', c%nu, ' inputs'
      call fail(c, iomsg)
    else if (c%seed < 0) then
      call fail(c, 'group &simulate: seed must be >= 0')
    else if (size(c%input_shape) /= c%nu .or. size(c%t_start) /= c%nu .or. &
             size(c%pulse_width) /= c%nu) then
      write (iomsg, '(a,i0,a)') 'group &simulate: input_shape, t_start and pulse_width take '// &
        'one value or one per input (', c%nu, ')'
      call fail(c, iomsg)
    end if
  end subroutine check_simulate

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

  !> &design (job 'design', kind 'linear'): the unknowns (elements of F, G
  !> or H; default: the free ones), the record's length t_end and step dt,
  !> the limit (energy, or peak and min_width), weights, servo time
  !> constants, process noise Gamma Q Gamma', method and iterations, and
  !> the record to write.
  subroutine read_design_group(rd, c)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    character(len=NAMELEN) :: unknowns(MAXFREE)
    character(len=16) :: method
    character(len=PATHLEN) :: out
    real(wp) :: t_end, dt, energy, peak, min_width, weights(MAXFREE), servo(MAXU), &
                process_noise(MAXX*MAXX)
    integer :: iterations, ios
    character(len=msg_len) :: iomsg
    namelist /design/ unknowns, t_end, dt, energy, peak, min_width, weights, servo, &
      process_noise, method, iterations, out

    unknowns = ''
    method = ''
    out = ''
    t_end = 0.0_wp
    dt = 0.0_wp
    energy = UNSET
    peak = UNSET
    min_width = UNSET
    weights = UNSET
    servo = UNSET
    process_noise = UNSET
    iterations = 12
    rewind (rd%unit)
    read (rd%unit, nml=design, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'design', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    c%out_file = out
    c%t_end = t_end
    c%dt = dt
    c%design_method = to_lower(method)
    c%energy = merge(0.0_wp, energy, energy == UNSET)
    c%peak = merge(0.0_wp, peak, peak == UNSET)
    c%min_width = merge(0.0_wp, min_width, min_width == UNSET)
    c%iterations = iterations
    if (len_trim(method) == 0) c%design_method = merge('amplitude', 'operator ', peak /= UNSET)
    call design_model_check(c)
    if (c%status == MLID_OK) call design_unknowns(c, unknowns)
    if (c%status == MLID_OK) call design_settings(c, weights, servo, process_noise)
    if (c%status == MLID_OK) call design_limits(c, energy /= UNSET, peak /= UNSET .or. &
                                                min_width /= UNSET)
  end subroutine read_design_group

  !> What the design takes of &model: a linear model with inputs, no state
  !> feedback or stabilisation, measurement noise r > 0 on every output.
  subroutine design_model_check(c)
    type(case_t), intent(inout) :: c
    type(layout_table_t) :: lt
    integer :: ios, b
    character(len=msg_len) :: iomsg

    if (c%mkind /= MODEL_LINEAR .or. c%nu < 1) then
      call fail(c, 'group &design: input design needs kind = ''linear'' with at least one input')
      return
    end if
    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, ios, iomsg)
    do b = 1, lt%nblock
      if (all(lt%key(b) /= [character(len=8) :: 'k', 'stab', 'delay', 'udelay'])) cycle
      if (any(c%theta(lt%off(b) + 1:lt%off(b) + lt%rows(b)*max(1, lt%cols(b))) /= 0.0_wp)) then
        call fail(c, 'group &design: the design model is F, G, H; &model '//trim(lt%key(b))// &
                  ' must be zero')
        return
      end if
    end do
    b = findloc(lt%key, 'r', 1)
    if (.not. all(c%theta(lt%off(b) + 1:lt%off(b) + c%ny) > 0.0_wp)) &
      call fail(c, 'group &design: &model r (the measurement-noise variance of each output) '// &
                'must be > 0: the design''s noise spectral density is r dt')
  end subroutine design_model_check

  !> The unknowns: elements of F, G or H named in unknowns, else the free
  !> parameters; each labelled as &model names it when it is free.
  subroutine design_unknowns(c, unknowns)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: unknowns(:)
    type(layout_table_t) :: lt
    integer, allocatable :: idx(:)
    integer :: k, b, i, j, ios
    character(len=msg_len) :: iomsg

    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, ios, iomsg)
    if (any(len_trim(unknowns) > 0)) then
      allocate (idx(0))
      do k = 1, size(unknowns)
        if (len_trim(unknowns(k)) == 0) cycle
        i = element_index(lt, unknowns(k))
        if (i == 0) then
          call fail(c, 'group &design: unknown '''//trim(unknowns(k))//''' is no element '// &
                    'of F, G or H within the dimensions')
          return
        end if
        if (any(idx == i)) then
          call fail(c, 'group &design: unknown '''//trim(unknowns(k))//''' listed twice')
          return
        end if
        idx = [idx, i]
      end do
    else
      idx = pack([(k, k=1, size(c%theta))], c%isfree == 1)
    end if
    if (size(idx) == 0) then
      call fail(c, 'group &design: no unknowns: list them in &design unknowns or free them '// &
                'in &model')
      return
    end if
    allocate (c%ukind(size(idx)), c%urow(size(idx)), c%ucol(size(idx)), c%unknowns(size(idx)))
    do k = 1, size(idx)
      call locate(lt, idx(k), b, i, j)
      c%ukind(k) = findloc([character(len=8) :: 'f', 'g', 'h'], lt%key(b), 1)
      c%urow(k) = i
      c%ucol(k) = j
      c%unknowns(k) = element_name(lt, idx(k))
      if (c%isfree(idx(k)) == 1) c%unknowns(k) = c%labels(count(c%isfree(1:idx(k)) == 1))
      if (c%ukind(k) == 0) then
        call fail(c, 'group &design: unknown '''//trim(element_name(lt, idx(k)))//''' is '// &
                  'no element of F, G or H (the design''s unknowns are)')
        return
      end if
    end do
  end subroutine design_unknowns

  !> Weights (one per unknown, > 0; default ones), servo time constants
  !> (one, or one per input; >= 0, 0 for none) and process noise (nx x nx,
  !> row by row, symmetric; default none).
  subroutine design_settings(c, weights, servo, process_noise)
    type(case_t), intent(inout) :: c
    real(wp), intent(in) :: weights(:), servo(:), process_noise(:)
    integer :: m

    m = size(c%ukind)
    c%weights = pack(weights, weights /= UNSET)
    if (size(c%weights) == 0) c%weights = spread(1.0_wp, 1, m)
    c%servo = per_input(servo, c%nu)
    c%gq = transpose(reshape(pack(process_noise, process_noise /= UNSET), [c%nx, c%nx], &
                             pad=[0.0_wp]))
    if (size(c%weights) /= m .or. .not. all(c%weights > 0.0_wp .and. c%weights < UNSET)) then
      call fail(c, 'group &design: weights takes one value > 0 per unknown ('//itoa(m)//')')
    else if (size(c%servo) /= c%nu .or. .not. all(c%servo >= 0.0_wp .and. c%servo < UNSET)) then
      call fail(c, 'group &design: servo takes one time constant >= 0 (s; 0: none), or one '// &
                'per input ('//itoa(c%nu)//')')
    else if (all(count(process_noise /= UNSET) /= [0, c%nx*c%nx])) then
      call fail(c, 'group &design: process_noise is Gamma Q Gamma'' (nx x nx = '// &
                itoa(c%nx*c%nx)//' values, row by row), got '// &
                itoa(count(process_noise /= UNSET)))
    else if (any(abs(c%gq - transpose(c%gq)) > 1.0e-12_wp*maxval(abs(c%gq)))) then
      call fail(c, 'group &design: process_noise (Gamma Q Gamma'') must be symmetric')
    end if
  end subroutine design_settings

  !> The record (t_end a whole number of steps dt), the method and its
  !> limit: energy for operator, riccati and equalised (an even number of
  !> steps: the operator's finer grid is the record's); peak and min_width
  !> for amplitude.
  subroutine design_limits(c, has_energy, has_peak)
    type(case_t), intent(inout) :: c
    logical, intent(in) :: has_energy, has_peak
    integer :: n

    n = nint(c%t_end/max(c%dt, tiny(1.0_wp)))
    if (len_trim(c%out_file) == 0) then
      call fail(c, 'group &design: out (the record of the designed input to write) is missing')
    else if (.not. (c%dt > 0.0_wp .and. c%t_end > c%dt .and. c%t_end < UNSET)) then
      call fail(c, 'group &design: need dt > 0 and t_end > dt (the input''s length T, s)')
    else if (.not. (c%t_end/c%dt < real(MAX_SAMPLES, wp))) then
      call fail(c, 'group &design: t_end/dt is too many samples')
    else if (abs(n*c%dt - c%t_end) > 1.0e-9_wp*c%t_end) then
      call fail(c, 'group &design: t_end must be a whole number of steps dt')
    else if (all(c%design_method /= DESIGN_METHODS)) then
      call fail(c, 'group &design: method must be '//choices(DESIGN_METHODS)//', got '''// &
                trim(c%design_method)//'''')
    else if (c%design_method == 'amplitude') then
      if (has_energy .or. .not. (c%peak > 0.0_wp .and. c%min_width > 0.0_wp)) then
        call fail(c, 'group &design: method ''amplitude'' takes peak > 0 and min_width > 0 '// &
                  '(the shortest pulse, s), not energy')
      else if (c%min_width > c%t_end) then
        call fail(c, 'group &design: min_width is longer than t_end')
      end if
    else if (has_peak .or. .not. c%energy > 0.0_wp) then
      call fail(c, 'group &design: method '''//trim(c%design_method)//''' takes energy > 0 '// &
                '(the integral of u''u over T), not peak or min_width')
    else if (mod(n, 2) /= 0) then
      call fail(c, 'group &design: method '''//trim(c%design_method)//''' needs an even '// &
                'number of steps t_end/dt (its two grids are t_end/dt/2 and t_end/dt cells)')
    else if (c%iterations < 0) then
      call fail(c, 'group &design: iterations must be >= 0')
    end if
  end subroutine design_limits

  !> &monte_carlo (job 'monte_carlo'): runs from seed (run k: seed + k - 1),
  !> the record of the input flown (input_file) and the true values of the
  !> free parameters (in the order of free; default: the start values).
  subroutine read_monte_carlo_group(rd, c, free_idx)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    integer, intent(in) :: free_idx(:)
    integer :: runs, seed, ios, nf
    real(wp) :: truth(MAXFREE)
    character(len=PATHLEN) :: input_file
    character(len=msg_len) :: iomsg
    namelist /monte_carlo/ runs, seed, truth, input_file

    runs = 0
    seed = 1
    truth = UNSET
    input_file = ''
    rewind (rd%unit)
    read (rd%unit, nml=monte_carlo, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'monte_carlo', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    nf = size(free_idx)
    c%runs = runs
    c%seed = seed
    c%input_file = input_file
    c%theta_true = c%theta
    if (count(truth /= UNSET) > 0) c%theta_true(free_idx) = truth(1:nf)
    if (len_trim(input_file) == 0) then
      call fail(c, 'group &monte_carlo: input_file (the record of the input flown) is missing')
    else if (runs < 1 .or. runs > 1000000) then
      call fail(c, 'group &monte_carlo: runs must be 1 to 1000000, got '//itoa(runs))
    else if (seed < 0 .or. seed > huge(1) - runs) then
      call fail(c, 'group &monte_carlo: seed must be >= 0 (runs use seed, seed + 1, ...)')
    else if (nf == 0) then
      call fail(c, 'group &monte_carlo: nothing is free in &model: there is nothing to estimate')
    else if (all(count(truth /= UNSET) /= [0, nf]) .or. any(truth(nf + 1:) /= UNSET)) then
      call fail(c, 'group &monte_carlo: truth takes one value per free parameter ('// &
                itoa(nf)//', in the order of free), got '//itoa(count(truth /= UNSET)))
    else if (.not. all(ieee_is_finite(c%theta_true))) then
      call fail(c, 'group &monte_carlo: truth must be finite')
    end if
  end subroutine read_monte_carlo_group

  !> Path relative to the deck's folder unless absolute.
  function resolve(dir, file) result(path)
    character(len=*), intent(in) :: dir, file
    character(len=:), allocatable :: path
    if (file(1:1) == '/' .or. len_trim(dir) == 0) then
      path = trim(file)
    else
      path = trim(dir)//'/'//trim(file)
    end if
  end function resolve

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

end module mlid_deck
