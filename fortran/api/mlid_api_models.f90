!> The flat interface's models and options: the option table by name,
!> layouts and element names, ties, the six-degree-of-freedom and
!> flight-path models' text, parameter units, Jacobian checks, input
!> signals, and the core's name lists.
!> Conventions: mlid_api_deck's comment.
module mlid_api_models
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, stop_reason_text, fit_outcome
  use mlid_models, only: model_t
  use mlid_model_factory, only: model_create, MODEL_KIND_NAMES, MODEL_AERO_LONG
  use mlid_equations, only: equations_tables
  use mlid_long_text, only: longitudinal_text
  use mlid_options, only: options_t, options_from_flat, options_to_flat, NOPTION, OPTION_NAMES, &
                          option_kind, option_words, option_set, option_get
  use mlid_ties, only: tie_parse, MAXTERM
  use mlid_inputs, only: input_signal
  use mlid_signals, only: multisine_band, multisine, sweep, prbs, finish_signal
  use mlid_case, only: NAMELEN
  use mlid_text, only: join_lines, split_lines, name_lines, joined
  use mlid_sixdof, only: sixdof_parts, SIXDOF_CONSTANTS
  use mlid_flightpath, only: flightpath_text, flightpath_corrected, FLIGHTPATH_CONSTANTS, &
                             FLIGHTPATH_CORRECTIONS, FLIGHTPATH_OUTPUTS, FLIGHTPATH_INPUTS
  use mlid_record, only: record_text
  use mlid_units, only: UNITLEN
  use mlid_aero_long, only: REGRESSOR_NAMES, CONSTANT_NAMES, aero_long_iconst
  use mlid_param_units, only: param_units
  use mlid_layout, only: layout_table_t, layout_of, element_name, default_label, manoeuvre_map, &
                         manoeuvre_suffix, element_index, element_problem
  use mlid_jacobian_check, only: check_jacobians
  use mlid_named, only: named_t, VALUE_KIND_NAMES
  use mlid_run, only: corrected_record
  use mlid_handles, only: session_t, handle_session, call_session
  use mlid_problem, only: problem_needs, PART_MODEL, PART_PARAMS, PART_RECORD
  use mlid_initial_states, only: x0_from_record
  use mlid_input_ranking, only: CANDIDATE_NAMES
  implicit none
  private
  public :: mlid_input_signal, mlid_multisine_count, mlid_multisine, mlid_sweep, mlid_prbs, &
            mlid_finish_signal, mlid_default_options, mlid_option_info, mlid_option_choices, &
            mlid_option_set, mlid_option_get, mlid_options_check, mlid_stop_reason, mlid_fit_outcome, &
            mlid_tie_parse, mlid_sixdof_constants, mlid_sixdof_text, mlid_flightpath_lists, &
            mlid_flightpath_model_text, mlid_flightpath_corrected, mlid_layout, &
            mlid_manoeuvre_map, mlid_elements, mlid_longitudinal_iconst, mlid_parameter_units, &
            mlid_name_list, mlid_limit, mlid_model_sizes, mlid_check_jacobians, mlid_x0_from, &
            mlid_model_tables, mlid_longitudinal_text, mlid_model_point

contains

  !> A standard input shape (mlid_inputs) on t = 0, dt, ..., (nt-1)*dt.
  subroutine mlid_input_signal(shape, amplitude, t_start, pulse_width, dt, nt, u, status, msg)
    character(len=*), intent(in) :: shape
    real(c_double), intent(in) :: amplitude, t_start, pulse_width, dt
    integer(c_int), intent(in) :: nt
    real(c_double), intent(out) :: u(nt)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call input_signal(shape, amplitude, t_start, pulse_width, dt, u, status, msg)
  end subroutine mlid_input_signal

  !> How many harmonics of 1/(nt*dt) the band [f_min, f_max] holds for m
  !> inputs (mlid_signals' multisine_band), to size mlid_multisine's arrays.
  subroutine mlid_multisine_count(f_min, f_max, dt, nt, m, nh, status, msg)
    real(c_double), intent(in) :: f_min, f_max, dt
    integer(c_int), intent(in) :: nt, m
    integer(c_int), intent(out) :: nh, status
    character(len=256), intent(out) :: msg
    integer, allocatable :: k(:), owner(:)
    call multisine_band(f_min, f_max, dt, nt, m, k, owner, status, msg)
    nh = size(k)
  end subroutine mlid_multisine_count

  !> m orthogonal multisines with minimised RPF (mlid_signals' multisine):
  !> band = f_min, f_max [Hz], dt [s]; pw(nh) relative powers of the band's
  !> harmonics, amp(m) peaks, iters clipping steps; out: u(nt+1,m) on
  !> t = 0..nt*dt, harm(nh,4) each harmonic's number, input, phase and
  !> amplitude, rpf(m,2) each input's Schroeder and final RPF.
  subroutine mlid_multisine(band, nt, m, nh, pw, amp, iters, u, harm, rpf, status, msg)
    real(c_double), intent(in) :: band(3)
    integer(c_int), intent(in) :: nt, m, nh, iters
    real(c_double), intent(in) :: pw(nh), amp(m)
    real(c_double), intent(out) :: u(nt + 1, m), harm(nh, 4), rpf(m, 2)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    integer, allocatable :: k(:), own(:)
    u = 0
    harm = 0
    rpf = 0
    call multisine_band(band(1), band(2), band(3), nt, m, k, own, status, msg)
    if (status /= MLID_OK) return
    if (size(k) /= nh) then
      status = MLID_ERR_INPUT
      msg = 'multisine: the band holds a different number of harmonics than the powers given'
      return
    end if
    harm(:, 1) = k
    harm(:, 2) = own
    call multisine(k, own, pw, amp, iters, u, harm(:, 3), harm(:, 4), rpf(:, 1), rpf(:, 2), &
                   status, msg)
  end subroutine mlid_multisine

  !> A linear or logarithmic sweep (mlid_signals' sweep); finishing is
  !> mlid_finish_signal's.
  subroutine mlid_sweep(kind, f0, f1, a0, a1, t_fade, dt, nt, u, status, msg)
    character(len=*), intent(in) :: kind
    real(c_double), intent(in) :: f0, f1, a0, a1, t_fade, dt
    integer(c_int), intent(in) :: nt
    real(c_double), intent(out) :: u(nt)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call sweep(kind, f0, f1, a0, a1, t_fade, dt, u, status, msg)
  end subroutine mlid_sweep

  !> A maximal-length PRBS of order n, bits nclock samples long, +-a
  !> (mlid_signals' prbs); finishing is mlid_finish_signal's.
  subroutine mlid_prbs(n, nclock, a, nt, u, status, msg)
    integer(c_int), intent(in) :: n, nclock, nt
    real(c_double), intent(in) :: a
    real(c_double), intent(out) :: u(nt)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call prbs(n, nclock, a, u, status, msg)
  end subroutine mlid_prbs

  !> Any signal x made to start and end at zero with zero mean (zero /= 0)
  !> and scaled to max |u| <= limit (limit > 0): mlid_signals' finish_signal.
  subroutine mlid_finish_signal(x, nt, zero, limit, u, status, msg)
    integer(c_int), intent(in) :: nt, zero
    real(c_double), intent(in) :: x(nt), limit
    real(c_double), intent(out) :: u(nt)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    u = x
    call finish_signal(u, zero /= 0, limit, status, msg)
  end subroutine mlid_finish_signal

  !> The default options, so that Python and decks share one set.
  subroutine mlid_default_options(iopt, ropt)
    integer(c_int), intent(out) :: iopt(16)
    real(c_double), intent(out) :: ropt(16)
    call options_to_flat(options_t(), iopt, ropt)
  end subroutine mlid_default_options

  !> Option k of the core's table (k = 1, 2, ...): its name and kind
  !> ('int', 'real', 'bool', 'choice'); name is blank past the last one.
  subroutine mlid_option_info(k, name, kind)
    integer(c_int), intent(in) :: k
    character(len=16), intent(out) :: name, kind
    name = ''
    kind = ''
    if (k < 1 .or. k > NOPTION) return
    name = OPTION_NAMES(k)
    kind = option_kind(name)
  end subroutine mlid_option_info

  !> The words option name takes, blank-separated ('' for a number).
  subroutine mlid_option_choices(name, words)
    character(len=*), intent(in) :: name
    character(len=80), intent(out) :: words
    words = option_words(name)
  end subroutine mlid_option_choices

  !> Set an option by name from its text in the flat arrays.
  subroutine mlid_option_set(iopt, ropt, name, text, status, msg)
    integer(c_int), intent(inout) :: iopt(16)
    real(c_double), intent(inout) :: ropt(16)
    character(len=*), intent(in) :: name, text
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call option_set(iopt, ropt, name, text, status, msg)
  end subroutine mlid_option_set

  !> An option's value as text, by name.
  subroutine mlid_option_get(iopt, ropt, name, text)
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16)
    character(len=*), intent(in) :: name
    character(len=32), intent(out) :: text
    text = option_get(iopt, ropt, name)
  end subroutine mlid_option_get

  !> Check a whole set of flat options (ranges, limits) before any work.
  subroutine mlid_options_check(iopt, ropt, status, msg)
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(options_t) :: opt
    call options_from_flat(iopt, ropt, opt, status, msg)
  end subroutine mlid_options_check

  !> Why an iteration stopped, in words (the report's text).
  subroutine mlid_stop_reason(reason, text)
    integer(c_int), intent(in) :: reason
    character(len=64), intent(out) :: text
    text = stop_reason_text(reason)
  end subroutine mlid_stop_reason

  !> What a fit that ended with status and reason has to show (mlid_kinds
  !> FIT_*: 0 estimates, 1 failed, only the last values, 2 not run).
  subroutine mlid_fit_outcome(status, reason, outcome)
    integer(c_int), intent(in) :: status, reason
    integer(c_int), intent(out) :: outcome
    outcome = fit_outcome(status, reason)
  end subroutine mlid_fit_outcome

  !> A tie written as text (mlid_ties) for the model of handle h's problem:
  !> given 'text'; results 'to' (the tied entry), 'offset', and its terms
  !> 'from' and 'scale' (at most MAXTERM).
  subroutine mlid_tie_parse(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(layout_table_t) :: lt
    character(len=:), allocatable :: text
    integer :: to, n, from(MAXTERM)
    real(wp) :: offset, scale(MAXTERM)
    call model_layout(h, s, lt, status, msg)
    if (status /= MLID_OK) return
    call s%given%get('text', text, status, msg)
    if (status == MLID_OK) call tie_parse(lt, text, to, offset, n, from, scale, status, msg)
    if (status /= MLID_OK) return
    call s%results%put('to', to)
    call s%results%put('offset', offset)
    call s%results%put('from', from(1:n))
    call s%results%put('scale', scale(1:n))
  end subroutine mlid_tie_parse

  !> The six-degree-of-freedom model's constants, in their order.
  subroutine mlid_sixdof_constants(names)
    character(len=64), intent(out) :: names
    names = SIXDOF_CONSTANTS
  end subroutine mlid_sixdof_constants

  !> The six-degree-of-freedom model's own lines (mlid_sixdof) for the
  !> states, inputs and definitions' names given one a line: what goes
  !> before the user's definitions, after them, and the state equations.
  subroutine mlid_sixdof_text(consts, states, inputs, defined, pre, post, xs, status, msg)
    real(c_double), intent(in) :: consts(9)
    character(len=*), intent(in) :: states, inputs, defined
    character(len=16384), intent(out) :: pre, post, xs
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    character(len=:), allocatable :: a, b, x
    character(len=NAMELEN), allocatable :: xn(:), un(:), dn(:)
    call name_lines(states, xn)
    call name_lines(inputs, un)
    call name_lines(defined, dn)
    call sixdof_parts(consts, xn, un, dn, a, b, x, status, msg)
    pre = ''
    post = ''
    xs = ''
    if (status /= MLID_OK) return
    pre = a
    post = b
    xs = x
  end subroutine mlid_sixdof_text

  !> The flight-path model's constants, corrections, outputs and inputs,
  !> each list comma-separated in its order (mlid_flightpath).
  subroutine mlid_flightpath_lists(constants, corrections, outputs, inputs)
    character(len=256), intent(out) :: constants, corrections, outputs, inputs
    constants = FLIGHTPATH_CONSTANTS
    corrections = joined(FLIGHTPATH_CORRECTIONS)
    outputs = joined(FLIGHTPATH_OUTPUTS)
    inputs = joined(FLIGHTPATH_INPUTS)
  end subroutine mlid_flightpath_lists

  !> The flight-path model's text (mlid_flightpath) for its constants, the
  !> corrections present and the outputs, names given one a line.
  subroutine mlid_flightpath_model_text(consts, corrections, outputs, text, status, msg)
    real(c_double), intent(in) :: consts(7)
    character(len=*), intent(in) :: corrections, outputs
    character(len=16384), intent(out) :: text
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    character(len=:), allocatable :: a
    character(len=NAMELEN), allocatable :: pn(:), yn(:)
    call name_lines(corrections, pn)
    call name_lines(outputs, yn)
    call flightpath_text(consts, pn, yn, a, status, msg)
    text = ''
    if (status == MLID_OK) text = a
  end subroutine mlid_flightpath_model_text

  !> One manoeuvre of a flight-path model's fit with its corrections undone
  !> (mlid_run's corrected_record): handle h's problem gives the model (by
  !> its text, iconst) and the manoeuvre's record; given are its corrections
  !> 'p', output 'bias' and 'delay', input 'udelay', the channels' 'names'
  !> and 'units' (one a line, inputs then outputs) and 'path' (not blank:
  !> the record is also written there, whole or not at all).  Results 'uc'
  !> and 'yc', the record's inputs and outputs corrected.
  subroutine mlid_flightpath_corrected(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    real(wp), allocatable :: p(:), bias(:), delay(:), udelay(:), uc(:, :), yc(:, :)
    character(len=:), allocatable :: names, units, path
    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call problem_needs(s%problem, [PART_MODEL, PART_RECORD], status, msg)
    if (status /= MLID_OK) return
    associate (pb => s%problem, g => s%given)
      call g%get('p', p, status, msg)
      call g%get('bias', bias, status, msg, [pb%ny])
      call g%get('delay', delay, status, msg, [pb%ny])
      call g%get('udelay', udelay, status, msg, [pb%nu])
      call g%get('names', names, status, msg)
      call g%get('units', units, status, msg)
      call g%get('path', path, status, msg)
      if (status /= MLID_OK) return
      allocate (uc(pb%nu, size(pb%t)), yc(pb%ny, size(pb%t)))
      call corrected_record(pb%iconst, p, bias, delay, udelay, pb%t, pb%u, pb%y, &
                            split_lines(names, pb%nu + pb%ny, NAMELEN), &
                            split_lines(units, pb%nu + pb%ny, NAMELEN), path, uc, yc, status, msg)
    end associate
    if (status /= MLID_OK) return
    call s%results%put('uc', uc)
    call s%results%put('yc', yc)
  end subroutine mlid_flightpath_corrected

  !> x0 from the record (mlid_initial_states, as a deck's &estimate
  !> x0_from): handle h's problem gives the model, its parameters (laid out
  !> for its record's manoeuvres) and the record; given 'rule' ('first' or
  !> 'mean') and 'samples' (k, 'mean'); result 'theta', the parameters with
  !> each manoeuvre's measured states' x0 from its own samples.
  subroutine mlid_x0_from(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    character(len=:), allocatable :: rule
    real(wp), allocatable :: theta(:)
    integer :: k
    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call problem_needs(s%problem, [PART_MODEL, PART_PARAMS, PART_RECORD], status, msg)
    if (status == MLID_OK) call s%given%get('rule', rule, status, msg)
    if (status == MLID_OK) call s%given%get('samples', k, status, msg)
    if (status /= MLID_OK) return
    associate (pb => s%problem)
      theta = pb%theta
      call x0_from_record(pb%mkind, pb%nx, pb%nu, pb%ny, pb%nw, pb%iconst, pb%rconst, theta, &
                          pb%y, pb%segstart, rule, k, status, msg)
    end associate
    if (status == MLID_OK) call s%results%put('theta', theta)
  end subroutine mlid_x0_from

  !> The parameter layout of handle h's problem's model (mlid_layout), as
  !> results: each block's 'keys' (one a line), 'rows', 'cols' (-1: a
  !> vector) and 'offsets' in theta; each entry's element 'names' and
  !> default 'labels' (one a line); and for the longitudinal model each
  !> coefficient's 'regressors' (one a line: C_D's, C_L's, C_m's; blank for
  !> other kinds), so that no front end reads them off iconst.
  subroutine mlid_layout(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(layout_table_t) :: lt
    character(len=32), allocatable :: each(:)
    integer :: k

    call model_layout(h, s, lt, status, msg)
    if (status /= MLID_OK) return
    associate (nb => lt%nblock, r => s%results)
      each = lt%key(1:nb)
      call r%put('keys', join_lines(each))
      call r%put('rows', lt%rows(1:nb))
      call r%put('cols', lt%cols(1:nb))
      call r%put('offsets', lt%off(1:nb))
      each = [(element_name(lt, k), k=1, lt%nth)]
      call r%put('names', join_lines(each))
      each = [(default_label(lt, k), k=1, lt%nth)]
      call r%put('labels', join_lines(each))
      each = REGRESSOR_NAMES(lt%codes)     ! (codes: none but the longitudinal model's)
      call r%put('regressors', join_lines(each))
    end associate
  end subroutine mlid_layout

  !> The longitudinal model's iconst (mlid_aero_long's aero_long_iconst)
  !> from the regressors of C_D, C_L and C_m by name: given 'cd', 'cl' and
  !> 'cm', one a line; result 'iconst'.
  subroutine mlid_longitudinal_iconst(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    character(len=:), allocatable :: cd, cl, cm
    character(len=64), allocatable :: dnames(:), lnames(:), mnames(:)
    integer, allocatable :: iconst(:)
    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call s%given%get('cd', cd, status, msg)
    call s%given%get('cl', cl, status, msg)
    call s%given%get('cm', cm, status, msg)
    if (status /= MLID_OK) return
    call name_lines(cd, dnames)
    call name_lines(cl, lnames)
    call name_lines(cm, mnames)
    call aero_long_iconst(dnames, lnames, mnames, iconst, status, msg)
    if (status == MLID_OK) call s%results%put('iconst', iconst)
  end subroutine mlid_longitudinal_iconst

  !> The parameters named by 'names' (given, one a line) of handle h's
  !> problem's model (mlid_layout's element_index: key(i), key(i,j), an
  !> equations model's own names): results 'written', each as the model
  !> writes it ('f(1,2)'; '' for none), and 'problem', why each that is none
  !> is not one (element_problem), one a line.
  subroutine mlid_elements(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(layout_table_t) :: lt
    character(len=:), allocatable :: text
    character(len=512), allocatable :: names(:), written(:), problem(:)
    integer :: k, idx
    call model_layout(h, s, lt, status, msg)
    if (status /= MLID_OK) return
    call s%given%get('names', text, status, msg)
    if (status /= MLID_OK) return
    call name_lines(text, names)
    allocate (written(size(names)), problem(size(names)))
    do k = 1, size(names)
      idx = element_index(lt, names(k))
      written(k) = ''
      if (idx > 0) written(k) = element_name(lt, idx)
      problem(k) = element_problem(lt, names(k))
    end do
    call s%results%put('written', join_lines(written))
    call s%results%put('problem', join_lines(problem))
  end subroutine mlid_elements

  !> theta of handle h's problem's model for 'nseg' manoeuvres (given;
  !> mlid_layout's manoeuvre_map): results 'map' and 'seg', entry k copying
  !> entry map(k) of the one-manoeuvre theta and belonging to manoeuvre
  !> seg(k), 0 if shared, and 'suffix', what each entry's label gets after
  !> its name ('#2' or nothing; manoeuvre_suffix), one a line.
  subroutine mlid_manoeuvre_map(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(layout_table_t) :: lt
    integer, allocatable :: m(:), sg(:)
    character(len=12), allocatable :: suffix(:)
    integer :: nseg, k
    call model_layout(h, s, lt, status, msg)
    if (status /= MLID_OK) return
    call s%given%get('nseg', nseg, status, msg)
    if (status /= MLID_OK) return
    call manoeuvre_map(lt, max(nseg, 1), m, sg)
    call s%results%put('map', m)
    call s%results%put('seg', sg)
    allocate (suffix(size(sg)))
    do k = 1, size(sg)
      suffix(k) = manoeuvre_suffix(sg(k), nseg)
    end do
    call s%results%put('suffix', join_lines(suffix))
  end subroutine mlid_manoeuvre_map

  !> The unit of every entry of 'theta' (given) of handle h's problem's
  !> model (mlid_param_units) from its record's channel units
  !> ('input_units', 'output_units' given, one a line, core units): result
  !> 'units', one a line.
  subroutine mlid_parameter_units(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(layout_table_t) :: lt
    real(wp), allocatable :: theta(:)
    character(len=:), allocatable :: input_units, output_units
    character(len=UNITLEN), allocatable :: each(:)
    call model_layout(h, s, lt, status, msg)
    if (status /= MLID_OK) return
    call s%given%get('theta', theta, status, msg, [lt%nth])
    call s%given%get('input_units', input_units, status, msg)
    call s%given%get('output_units', output_units, status, msg)
    if (status /= MLID_OK) return
    allocate (each(lt%nth))
    call param_units(lt, theta, split_lines(input_units, s%problem%nu, UNITLEN), &
                     split_lines(output_units, s%problem%ny, UNITLEN), each)
    call s%results%put('units', join_lines(each))
  end subroutine mlid_parameter_units

  !> A limit of the core by name, for the front ends to size their calls:
  !> 'tie_terms' (the terms of one tie, mlid_ties' MAXTERM); 0 for a name it
  !> does not know.
  subroutine mlid_limit(name, value)
    character(len=*), intent(in) :: name
    integer(c_int), intent(out) :: value
    value = 0
    select case (name)
    case ('tie_terms')
      value = MAXTERM
    end select
  end subroutine mlid_limit

  !> A list of names the core defines, one per line: 'regressors' (of the
  !> longitudinal model, by code), 'constants' (its rconst, in order),
  !> 'value_kinds' and 'model_kinds' (by code), 'ranking_candidates' (the
  !> inputs the design ranks, mlid_input_ranking).
  subroutine mlid_name_list(which, text)
    character(len=*), intent(in) :: which
    character(len=1024), intent(out) :: text
    integer :: k
    text = ''
    select case (which)
    case ('regressors')
      do k = 1, size(REGRESSOR_NAMES)
        text = trim(text)//trim(REGRESSOR_NAMES(k))//achar(10)
      end do
    case ('constants')
      text = CONSTANT_NAMES
    case ('value_kinds')          ! mlid_named's kinds of value, in the order of their codes
      text = VALUE_KIND_NAMES
    case ('model_kinds')          ! the model kinds' names, in the order of their codes
      do k = 1, size(MODEL_KIND_NAMES)
        text = trim(text)//trim(MODEL_KIND_NAMES(k))//achar(10)
      end do
    case ('ranking_candidates')
      do k = 1, size(CANDIDATE_NAMES)
        text = trim(text)//trim(CANDIDATE_NAMES(k))//achar(10)
      end do
    end select
  end subroutine mlid_name_list

  !> Sizes of a model whose sizes are its own (longitudinal, user): give
  !> nx = nu = ny = nw = -1 to learn them.
  subroutine mlid_model_sizes(mkind, nic, iconst, nrc, rconst, nx, nu, ny, nw, np, status, msg)
    integer(c_int), intent(in) :: mkind, nic, nrc
    integer(c_int), intent(in) :: iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    integer(c_int), intent(out) :: nx, nu, ny, nw, np, status
    character(len=256), intent(out) :: msg
    class(model_t), allocatable :: m

    nx = 0
    nu = 0
    ny = 0
    nw = 0
    np = 0
    call model_create(mkind, -1, -1, -1, -1, iconst, rconst, m, status, msg)
    if (status /= MLID_OK) return
    nx = m%nx
    nu = m%nu
    ny = m%ny
    nw = m%nw
    np = m%np
  end subroutine mlid_model_sizes

  !> Largest relative differences between the analytic Jacobians (df/dx,
  !> df/dp, dh/dx, dh/dp, df/dw, dh/dw) of handle h's problem's model and
  !> central differences at the given 'p', 'x', 'u' and 'w'.
  subroutine mlid_check_jacobians(h, err, status, msg)
    integer(c_int64_t), intent(in) :: h
    real(c_double), intent(out) :: err(6)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    class(model_t), allocatable :: m
    real(wp), allocatable :: p(:), x(:), u(:), w(:)

    err = 0.0_wp
    call handle_session(h, s, status, msg)
    if (status == MLID_OK) call model_at_point(s, m, p, x, u, status, msg)
    if (status == MLID_OK) call s%given%get('w', w, status, msg, [s%problem%nw])
    if (status /= MLID_OK) return
    call check_jacobians(m, 0.0_wp, x, [u, w], p, err)
  end subroutine mlid_check_jacobians

  !> A model at one point (given 'p', 'x', 'u' and 't', the process noise
  !> zero): results 'y', the outputs h without the output biases, and
  !> 'xdot', the state derivatives f; nothing is integrated.
  subroutine mlid_model_point(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    class(model_t), allocatable :: m
    real(wp), allocatable :: p(:), x(:), u(:), t(:), y(:), xdot(:)

    call call_session(h, s, status, msg)
    if (status == MLID_OK) call model_at_point(s, m, p, x, u, status, msg)
    if (status == MLID_OK) call s%given%get('t', t, status, msg, [1])
    if (status /= MLID_OK) return
    allocate (y(m%ny), xdot(m%nx), stat=status)
    if (status /= 0) then
      status = MLID_ERR_INPUT
      msg = 'model point: no memory for the outputs'
      return
    end if
    u = [u, spread(0.0_wp, 1, m%nw)]         ! the model's inputs carry w after u
    call m%f(t(1), x, u, p, xdot)
    call m%h(t(1), x, u, p, y)
    call s%results%put('y', y)
    call s%results%put('xdot', xdot)
  end subroutine mlid_model_point

  !> The model of session s's problem and the point given to it ('p', 'x',
  !> 'u'; p the model's np parameters): what mlid_check_jacobians and
  !> mlid_model_point share.
  subroutine model_at_point(s, m, p, x, u, status, msg)
    type(session_t), pointer, intent(in) :: s
    class(model_t), allocatable, intent(out) :: m
    real(wp), allocatable, intent(out) :: p(:), x(:), u(:)
    integer(c_int), intent(out) :: status
    character(len=*), intent(out) :: msg
    call problem_needs(s%problem, [PART_MODEL], status, msg)
    if (status /= MLID_OK) return
    associate (pb => s%problem, g => s%given)
      call g%get('p', p, status, msg)
      if (status == MLID_OK) call g%get('x', x, status, msg, [pb%nx])
      if (status == MLID_OK) call g%get('u', u, status, msg, [pb%nu])
      if (status /= MLID_OK) return
      call model_create(pb%mkind, pb%nx, pb%nu, pb%ny, pb%nw, pb%iconst, pb%rconst, m, status, &
                        msg)
    end associate
    if (status /= MLID_OK) return
    if (m%np /= size(p)) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0)') 'the model has ', m%np, ' parameters, not ', size(p)
    end if
  end subroutine model_at_point

  !> The tables of handle h's problem's model (an equations model's,
  !> mlid_tables): results 'cells', each parameter's text (a table value's
  !> name and where it is weighted; '' for others, one a line, in p order),
  !> and 'weight', the smoothness prior's weight (np x np) for the given
  !> 'smoothness' (each table's weight, in the text's order).
  subroutine mlid_model_tables(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    class(model_t), allocatable :: m
    real(wp), allocatable :: lambda(:), w(:, :)
    character(len=160), allocatable :: texts(:)

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call problem_needs(s%problem, [PART_MODEL], status, msg)
    if (status /= MLID_OK) return
    associate (pb => s%problem)
      call model_create(pb%mkind, pb%nx, pb%nu, pb%ny, pb%nw, pb%iconst, pb%rconst, m, status, &
                        msg)
    end associate
    if (status /= MLID_OK) return
    call s%given%get('smoothness', lambda, status, msg)
    if (status /= MLID_OK) return
    allocate (texts(m%np), w(m%np, m%np))
    call equations_tables(m, lambda, texts, w, status, msg)
    if (status /= MLID_OK) return
    call s%results%put('cells', join_lines(texts))
    call s%results%put('weight', w)
  end subroutine mlid_model_tables

  !> The longitudinal model of handle h's problem written as equations
  !> (mlid_long_text), its coefficients named by the given 'tables' (table
  !> lines 'C_Lalpha(alpha) = 0 0.1 0.2', one a line) made tables: result
  !> 'text'.
  subroutine mlid_longitudinal_text(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    character(len=:), allocatable :: given, text
    character(len=512), allocatable :: tables(:)

    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call problem_needs(s%problem, [PART_MODEL], status, msg)
    if (status /= MLID_OK) return
    call s%given%get('tables', given, status, msg)
    if (status /= MLID_OK) return
    if (s%problem%mkind /= MODEL_AERO_LONG) then
      status = MLID_ERR_INPUT
      msg = 'longitudinal text: the model is not a longitudinal one'
      return
    end if
    call name_lines(given, tables)
    associate (pb => s%problem)
      call longitudinal_text(pb%iconst, pb%rconst, tables, text, status, msg)
    end associate
    if (status == MLID_OK) call s%results%put('text', text)
  end subroutine mlid_longitudinal_text

  !> The session of h, its results emptied, and the layout of its problem's
  !> model (the part the layout calls above share).
  subroutine model_layout(h, s, lt, status, msg)
    integer(c_int64_t), intent(in) :: h
    type(session_t), pointer, intent(out) :: s
    type(layout_table_t), intent(out) :: lt
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call problem_needs(s%problem, [PART_MODEL], status, msg)
    if (status /= MLID_OK) return
    associate (pb => s%problem)
      call layout_of(pb%mkind, pb%nx, pb%nu, pb%ny, pb%nw, pb%iconst, pb%rconst, lt, status, msg)
    end associate
  end subroutine model_layout

end module mlid_api_models
