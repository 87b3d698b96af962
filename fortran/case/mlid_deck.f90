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
!>             out (the record of t and the inputs), state_penalty (K of
!>             report 7.6: one weight per state or nx x nx)          (design)
!>   &monte_carlo runs, seed, truth (per free parameter), input_file;
!>             &estimate's options for the fits                 (monte_carlo)
!>   &online   the online estimator and its settings, the history's record (online)
!>   &stepwise method, f_in, f_out, sig2_max, degree, knot_vars, knots,
!>             spline_degree, intercept, forced, coefficients, out: the model
!>             structure of each of &data's outputs from candidates made of
!>             its inputs (no &model)                             (stepwise)
!>   &estimate method, startup, max_iter, halvings, noise, partials, steady_state,
!>             process_noise, noise_criterion, filter_params, tol_cost, tol_step, tol_grad, rcond,
!>             prior, prior_weight,
!>             prior_decay, rank_min, rank_max, rank_rule, lower, upper (per free parameter, in the
!>             order of free), corrected (kind flight_path: one record per data file),
!>             f_min, f_max, n_freq (the band of the frequency-domain methods, Hz),
!>             x0_from, x0_samples (the measured states' x0 from each record)
!> A problem in one case is kept in that case (status, msg) and the others
!> are still read.  Python reads decks through this reader too, into a handle
!> (mlid_handles; mlid_api_deck's mlid_deck_* routines).
!>
!> This file holds the interface (the public names, the constants, reader_t,
!> and the interfaces of the submodules' procedures that other files call),
!> deck_read and the case-level driver (read_case, resolve_paths).  Its
!> submodules: a reader per group, mlid_deck_case (&case), mlid_deck_model
!> (&model), mlid_deck_equations (the &model kinds written as equations),
!> mlid_deck_data (&data), mlid_deck_estimate (&estimate), mlid_deck_jobs
!> (&simulate, &design, &monte_carlo); mlid_deck_reader (what the group
!> readers share); mlid_deck_record (what the front ends ask of a case once
!> read: its record, its manoeuvres' layout).
module mlid_deck
  use mlid_kinds, only: wp, msg_len, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: to_lower, itoa, read_text, line_t, add_line, control_character, es_text, &
                       choices, &
                       utf8_head
  use mlid_deck_scan, only: deck_scan, assignment_t, group_span_t, element_states, last_element, &
                            ABSENT, &
                            NULLED, GIVEN
  use mlid_files, only: same_file
  use mlid_case, only: case_t, NAMELEN, PATHLEN
  use mlid_options, only: options_t, options_to_flat, options_from_flat
  use mlid_units, only: UNITLEN
  use mlid_progress, only: progress_t
  implicit none
  private
  public :: case_t, deck_read, case_record, case_time_input, manoeuvre_layout, &
            case_param_units, holdout_case, manoeuvre_block, corrected_writable, NAMELEN, &
            PATHLEN, deck_groups

  integer, parameter :: MAXX = 30, MAXU = 30, MAXY = 30, MAXW = 10, MAXFREE = 200, MAXCOL = 100
  !> &simulate power's entries at the most (on the heap: decks read in small threads)
  integer, parameter :: MAX_HARMONICS = 4000
  integer, parameter :: MAXR = 12   !< regressors of each coefficient
  integer, parameter :: MAXDER = 50, CHANLEN = 64, EXPRLEN = 1024  !< &data entries
  integer, parameter :: TIELEN = 512                                !< a tie's or equation's text
  integer, parameter :: MAXDEF = 100                                !< an equations model's definitions
  integer, parameter :: MAXTABLES = 16                              !< &estimate smoothness entries
  !> The jobs of &case, and the groups each reads, in the order they are
  !> read (&case first: the job); a group of another job is refused.
  integer, parameter :: NJOB = 7
  character(len=12), parameter :: JOBS(NJOB) = [character(len=12) :: 'estimate', 'validate', &
                                                'simulate', 'design', 'monte_carlo', 'online', &
                                                'stepwise']
  character(len=40), parameter :: JOB_GROUPS(NJOB) = [character(len=40) :: &
    'case model data estimate', 'case model data estimate', 'case model simulate', &
    'case model design', 'case model monte_carlo estimate', 'case model data online', &
    'case data stepwise']
  character(len=*), parameter :: GROUP_NAMES = ' case model data simulate estimate design '// &
                                               'monte_carlo online stepwise '
  !> The names each group takes, in GROUP_NAMES' order: the same as its
  !> reader's namelist statement (tests/test_docs.py checks both ways), for
  !> the deck reference, which is made from this table (deck_groups).
  integer, parameter :: NGROUP = 9
  character(len=360), parameter :: GROUP_KEYS(NGROUP) = [character(len=360) :: &
    'title job mach altitude alpha_trim config tags', &
    'kind nx nu ny nw f g h d gamma k bx x0 bias q r s free names tie input_hold substeps '// &
    'state_names input_names output_names cd_regressors cl_regressors cm_regressors cd cl cm '// &
    'constants p user_iconst user_rconst xdot outputs definitions params initial_states delay '// &
    'udelay stab p0', &
    'file time_col input_cols output_cols skip_rows columns units derived show t_start t_end '// &
    'holdout dt join join_columns', &
    'out t_end dt seed noise_std input_shape amplitude t_start pulse_width input_file f_min f_max '// &
    'prbs_order amplitude_end limit zero_mean power phases', &
    'method startup max_iter halvings noise partials steady_state process_noise '// &
    'noise_criterion filter_params tol_cost tol_step tol_grad rcond prior prior_weight '// &
    'prior_decay rank_min rank_max rank_rule lower upper corrected f_min f_max n_freq x0_from '// &
    'x0_samples smoothness', &
    'unknowns t_end dt energy peak min_width weights servo process_noise method iterations out '// &
    'state_penalty candidates compare rank_by f_min f_max pulse_width', &
    'runs seed truth input_file', &
    'estimator f_min f_max n_freq every trim first forgetting p0 q delta r_fade out p_max timing', &
    'method f_in f_out sig2_max degree knot_vars knots spline_degree intercept forced '// &
    'coefficients out']
  character(len=*), parameter :: FORM_FEED = achar(12)

  !> What the group readers of one case share: the text of each group (all
  !> its namelist read is given), the case's lines (for line numbers in
  !> messages) and what its assignments set, element by element.
  type :: reader_t
    integer :: line0 = 0
    type(line_t), allocatable :: lines(:)
    type(assignment_t), allocatable :: given(:)   !< the case's assignments (deck_scan)
    type(group_span_t), allocatable :: spans(:)   !< its groups (deck_scan)
    type(line_t), allocatable :: texts(:)         !< each group's text, as spans
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

    !> The value rhs of an entry 'NAME = value' of a list: an expression of
    !> numbers, finite (the case fails, naming what and the entry, if not).
    module subroutine number_value(c, what, entry, rhs, v)
      type(case_t), intent(inout) :: c
      character(len=*), intent(in) :: what, entry, rhs
      real(wp), intent(out) :: v
    end subroutine number_value

    !> Set an option of the case by name from the deck's text.
    module subroutine set_option(c, where, name, text)
      type(case_t), intent(inout) :: c
      character(len=*), intent(in) :: where, name, text
    end subroutine set_option

    !> The text of group in the case ('' when the case has none): what its
    !> namelist read is given.
    module function group_text(rd, group) result(text)
      type(reader_t), intent(in) :: rd
      character(len=*), intent(in) :: group
      character(len=:), allocatable :: text
    end function group_text

    !> Whether scalar key of group was given a value.
    module logical function is_given(rd, group, key)
      type(reader_t), intent(in) :: rd
      character(len=*), intent(in) :: group, key
    end function is_given

    !> The elements of list key of group the deck gave (a value or a null):
    !> the first m of v, m the last one given, where a null keeps v's
    !> entry (its default, filled before the read).  An element left out
    !> before the last, or a null where has_default is false, fails the
    !> case.  full: the list's length when the deck names some of its
    !> elements by index alone (x0(2) = ...): those are set, the others keep
    !> their default (has_default), and out is v(1:full).
    module subroutine take_list(rd, c, group, key, v, out, has_default, full)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
      character(len=*), intent(in) :: group, key
      real(wp), intent(in) :: v(:)
      real(wp), allocatable, intent(out) :: out(:)
      logical, intent(in) :: has_default
      integer, intent(in), optional :: full
    end subroutine take_list

    !> Whether the deck gives key of group by index alone: every assignment
    !> of it has a subscript (x0(2) = ...), none gives the list whole.
    module logical function by_index(rd, group, key)
      type(reader_t), intent(in) :: rd
      character(len=*), intent(in) :: group, key
    end function by_index

    !> Lists given more than room entries fail the case, in words that name
    !> the limit, room what (the namelist read would blame a value): '20
    !> manoeuvres (data files)', '200 free parameters'.
    module subroutine at_most(rd, c, group, keys, room, what)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
      character(len=*), intent(in) :: group, keys(:), what
      integer, intent(in) :: room
    end subroutine at_most

    !> How many elements of list key (of room n) the deck gave, m (take_list).
    module subroutine list_length(rd, c, group, key, n, has_default, m)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
      character(len=*), intent(in) :: group, key
      integer, intent(in) :: n
      logical, intent(in) :: has_default
      integer, intent(out) :: m
    end subroutine list_length

    !> The line without its comment.
    module function strip_comment(line) result(s)
      character(len=*), intent(in) :: line
      character(len=len(line)) :: s
    end function strip_comment

    ! in mlid_deck_case

    !> &case: title, job and the flight condition.
    module subroutine read_case_group(rd, c)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
    end subroutine read_case_group

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
      real(wp), intent(in) :: constants(:)     !< those the deck gave
      character(len=*), intent(in) :: states(:), xdot(:), inputs(:), definitions(:)
      character(len=:), allocatable, intent(out) :: pre, post
      character(len=TIELEN), allocatable, intent(out) :: xs(:)
    end subroutine sixdof_deck

    !> kind = 'longitudinal' with tables: the model written as equations.
    module subroutine longitudinal_tables(c, lt, definitions, params)
      use mlid_layout, only: layout_table_t
      type(case_t), intent(inout) :: c
      type(layout_table_t), intent(inout) :: lt    !< the longitudinal model's, then the new one's
      character(len=*), intent(in) :: definitions(:), params(:)
    end subroutine longitudinal_tables

    !> The kinds whose model is a text of equations.
    module logical function written_as_equations(kind)
      character(len=*), intent(in) :: kind
    end function written_as_equations

    !> kind = 'flight_path': the kinematic model with its corrections.
    module subroutine flightpath_deck(c, constants, states, xdot, inputs, ynames, outputs, &
                                      definitions, params, pstart)
      type(case_t), intent(inout) :: c
      real(wp), intent(in) :: constants(:)     !< those the deck gave
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

    ! in mlid_deck_jobs

    !> &simulate: the record to write, its time base, inputs and noise.
    module subroutine read_simulate_group(rd, c)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
    end subroutine read_simulate_group

    !> &design: the input design's unknowns, record, limit and settings.
    module subroutine read_design_group(rd, c)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
    end subroutine read_design_group

    !> &monte_carlo: runs, seed, the input flown and the true values.
    module subroutine read_monte_carlo_group(rd, c, free_idx)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
      integer, intent(in) :: free_idx(:)
    end subroutine read_monte_carlo_group

    !> &online: the online estimator, its settings and the history's record.
    module subroutine read_online_group(rd, c, free_idx)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
      integer, intent(in) :: free_idx(:)
    end subroutine read_online_group

    ! in mlid_deck_stepwise

    !> &stepwise: model-structure determination of &data's outputs.
    module subroutine read_stepwise_group(rd, c)
      type(reader_t), intent(in) :: rd
      type(case_t), intent(inout) :: c
    end subroutine read_stepwise_group

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

    !> The record of an estimate case: time, inputs and outputs from its data
    !> files; progress: how far each is read (mlid_progress).
    module subroutine case_record(c, t, u, y, status, msg, segstart, units, names, notes, own_t, &
                                  shown, scale, progress)
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
      !> the unit each channel is shown in (deck `show`, else declared) and
      !> its scale: core = scale*shown + offset (a difference: core = scale*shown)
      character(len=UNITLEN), allocatable, intent(out), optional :: shown(:)
      real(wp), allocatable, intent(out), optional :: scale(:)
      type(progress_t), intent(inout), optional :: progress
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
    if (c%status == MLID_OK) call fail(c, 'file name '''//utf8_head(path, 40)// &
      '...'' is longer than '//itoa(PATHLEN - 1)//' bytes (with the deck''s folder)')
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
  !> one reader per group of its job, in JOB_GROUPS' order, each after the
  !> one before succeeded.
  subroutine read_case(lines, line0, c)
    type(line_t), intent(in) :: lines(:)
    integer, intent(in) :: line0
    type(case_t), intent(inout) :: c
    type(reader_t) :: rd
    type(case_t) :: scanned
    type(options_t) :: opt
    integer, allocatable :: free_idx(:)
    type(line_t), allocatable :: stripped(:)
    character(len=msg_len) :: msg, msg2
    character(len=:), allocatable :: groups
    integer :: k, status, status2, e

    ! Each group's namelist read is given that group's text alone, its
    ! comments stripped (gfortran and a Python reader disagree on comments
    ! after a trailing comma), from memory: no scratch file to be cut.
    ! deck_scan first checks the text as a whole (what a namelist read
    ! would pass over or take silently), and keeps its assignments.
    rd%line0 = line0
    rd%lines = lines
    allocate (stripped(size(lines)))
    status = MLID_OK
    do k = 1, size(lines)
      stripped(k)%s = strip_comment(lines(k)%s)
      call form_feeds(stripped(k)%s)
      msg2 = control_character(stripped(k)%s)
      if (len_trim(msg2) == 0) cycle
      stripped(k)%s = ''        ! neither to the scan nor to the title
      if (status /= MLID_OK) cycle
      status = MLID_ERR_INPUT
      msg = 'line '//itoa(line0 + k - 1)//': '//trim(msg2)
    end do
    ! the groups scanned up to a problem still give the case its title
    call deck_scan(stripped, line0, GROUP_NAMES, status2, msg2, rd%given, rd%spans)
    call span_texts(stripped, rd)
    if (status == MLID_OK) then
      status = status2
      msg = msg2
    end if
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
    if (c%status /= MLID_OK) return
    groups = groups_of_job(c%job)
    call other_jobs_groups(rd, c, groups)
    k = index(groups, ' ')            ! past 'case'
    do while (c%status == MLID_OK .and. k > 0 .and. k < len(groups))
      e = index(groups(k + 1:)//' ', ' ') + k
      select case (groups(k + 1:e - 1))
      case ('model')
        call read_model_group(rd, c, free_idx)
      case ('data')
        call read_data_group(rd, c)
        if (c%status == MLID_OK) call check_initial_states(c)
      case ('estimate')
        call read_estimate_group(rd, c, free_idx)
      case ('simulate')
        call read_simulate_group(rd, c)
      case ('design')
        call read_design_group(rd, c)
      case ('monte_carlo')
        call read_monte_carlo_group(rd, c, free_idx)
      case ('online')
        call read_online_group(rd, c, free_idx)
      case ('stepwise')
        call read_stepwise_group(rd, c)
      end select
      k = e
    end do
    if (c%status == MLID_OK .and. index(groups, ' data') == 0 .and. size(c%initial_states) > 0) &
      call fail(c, 'group &model: initial_states is for estimate cases (several data files)')
    if (c%status == MLID_OK .and. c%job == 'monte_carlo' .and. (c%use_prior == 1 .or. &
        c%use_bounds == 1 .or. allocated(c%corrected))) call fail(c, 'group &estimate: prior, '// &
        'bounds and corrected are not used by job ''monte_carlo'' (each run starts from &model)')
    if (c%status == MLID_OK) then
      call options_from_flat(c%iopt, c%ropt, opt, c%status, c%msg)
    end if
  end subroutine read_case

  !> The deck's groups, one line each: 'group|jobs that read it|its names',
  !> the lists blank-separated (GROUP_NAMES, JOB_GROUPS, GROUP_KEYS).
  function deck_groups() result(text)
    character(len=:), allocatable :: text, group, readers
    integer :: g, j, p, e
    text = ''
    p = 1
    do g = 1, NGROUP
      e = index(GROUP_NAMES(p + 1:), ' ') + p
      group = GROUP_NAMES(p + 1:e - 1)
      p = e
      readers = ''
      do j = 1, NJOB
        if (index(' '//trim(JOB_GROUPS(j))//' ', ' '//group//' ') > 0) &
          readers = readers//' '//trim(JOBS(j))
      end do
      text = text//group//'|'//trim(adjustl(readers))//'|'//trim(GROUP_KEYS(g))//achar(10)
    end do
  end function deck_groups

  !> The groups job reads (JOB_GROUPS), '' for no job.
  function groups_of_job(job) result(groups)
    character(len=*), intent(in) :: job
    character(len=:), allocatable :: groups
    integer :: j
    groups = ''
    j = findloc(JOBS, job, 1)
    if (j > 0) groups = trim(JOB_GROUPS(j))
  end function groups_of_job

  !> A group of the case that its job does not read is refused, not passed
  !> over (a &simulate in an estimate case was).
  subroutine other_jobs_groups(rd, c, groups)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: groups
    integer :: k
    do k = 1, size(rd%spans)
      if (index(' '//groups//' ', ' '//trim(rd%spans(k)%name)//' ') > 0) cycle
      call fail(c, 'line '//itoa(rd%spans(k)%line)//': group &'//trim(rd%spans(k)%name)// &
                ' is not read by job '''//trim(c%job)//''' (it reads &'// &
                replace_blanks(groups, ', &')//')')
      return
    end do
  end subroutine other_jobs_groups

  !> 'a b c' -> 'a, &b, &c' (sep ', &').
  function replace_blanks(words, sep) result(text)
    character(len=*), intent(in) :: words, sep
    character(len=:), allocatable :: text
    integer :: k
    text = ''
    do k = 1, len(words)
      if (words(k:k) == ' ') then
        text = text//sep
      else
        text = text//words(k:k)
      end if
    end do
  end function replace_blanks

  !> The text of each group the scan found: its lines from its & to its /,
  !> joined by blanks (an end of line is a blank to a namelist read, and
  !> no quoted text crosses one: deck_scan); '' for a group not closed.
  subroutine span_texts(stripped, rd)
    type(line_t), intent(in) :: stripped(:)
    type(reader_t), intent(inout) :: rd
    integer :: g, k, n, at, a, b
    allocate (rd%texts(size(rd%spans)))
    do g = 1, size(rd%spans)
      rd%texts(g)%s = ''
      if (rd%spans(g)%k2 == 0) cycle
      associate (sp => rd%spans(g))
        n = 0
        do k = sp%k1, sp%k2
          a = merge(sp%p1, 1, k == sp%k1)
          b = merge(sp%p2, len(stripped(k)%s), k == sp%k2)
          n = n + (b - a + 1) + 1
        end do
        deallocate (rd%texts(g)%s)
        allocate (character(len=n) :: rd%texts(g)%s)
        at = 0
        do k = sp%k1, sp%k2
          a = merge(sp%p1, 1, k == sp%k1)
          b = merge(sp%p2, len(stripped(k)%s), k == sp%k2)
          rd%texts(g)%s(at + 1:at + b - a + 2) = stripped(k)%s(a:b)//' '
          at = at + b - a + 2
        end do
      end associate
    end do
  end subroutine span_texts

  !> A form feed outside quoted text is a blank (a page break, as in the
  !> decks of old and in most languages' source text); in quoted text it
  !> stays, and is refused as a control character.
  subroutine form_feeds(s)
    character(len=*), intent(inout) :: s
    character :: quote
    integer :: k
    if (index(s, FORM_FEED) == 0) return
    quote = ' '
    do k = 1, len(s)
      if (quote /= ' ') then
        if (s(k:k) == quote) quote = ' '
      else if (s(k:k) == '''' .or. s(k:k) == '"') then
        quote = s(k:k)
      else if (s(k:k) == FORM_FEED) then
        s(k:k) = ' '
      end if
    end do
  end subroutine form_feeds

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

  !> The first word of line, lower case, after blanks, TABs and form feeds
  !> (a TAB before '&case' starts a case too).
  function first_word(line) result(w)
    character(len=*), intent(in) :: line
    character(len=16) :: w
    integer :: b, e
    w = ''
    b = verify(line, ' '//achar(9)//FORM_FEED)
    if (b == 0) return
    e = scan(line(b:), ' /,'//achar(9)//FORM_FEED)
    if (e == 0) e = len(line) - b + 2
    w = to_lower(line(b:b + min(e - 1, 16) - 1))
  end function first_word

end module mlid_deck
