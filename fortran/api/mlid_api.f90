!> The flat interface of the core: plain explicit-shape arrays of C kinds,
!> a status code and a message out.  f2py wraps this module as mlid._core,
!> and the batch program calls the same routines, so both give the same
!> numbers.
!>
!> Common arguments:
!>   mkind, nx, nu, ny, nw   model kind (1 = linear state space), sizes, noise inputs
!>   theta(nth)              all parameters [p, x0, bias, q, r, s] (mlid_models)
!>   isfree(nth)             1 where the parameter is estimated, else 0
!>   ntie, mtie, tie_to, tie_from, tie_scale (mtie >= max(ntie, 1)), tie_offset(nth)
!>                           affine ties: theta(to) := offset(to) + sum scale*theta(from)
!>   iconst, rconst          model constants (unused by the linear model)
!>   t(nt), u(nu,nt), y(ny,nt)   the record, one column per sample
!>   iopt(16), ropt(16)      options, layout in mlid_options
!>   status, msg             0 and '' on success, see mlid_kinds
module mlid_api
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan, ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, stop_reason_text, fit_outcome
  use mlid_models, only: model_t
  use mlid_model_factory, only: model_create
  use mlid_options, only: options_t, options_from_flat, options_to_flat, NOPTION, OPTION_NAMES, &
                          option_kind, option_set, option_get, frequency_method, NOPT, &
                          METHOD_FREQ_EE
  use mlid_params, only: param_map_t, param_map_create, apply_ties, tie_t, no_ties
  use mlid_ties, only: tie_parse, MAXTERM
  use mlid_likelihood, only: likelihood, sens_keep_t, weighted_sensitivities
  use mlid_newton, only: fit_result_t
  use mlid_fit_driver, only: fit_solve, fit_view, fit_view_t
  use mlid_colored, only: colored_covariance, colored_sandwich
  use mlid_linalg, only: sym_eig
  use mlid_simulate, only: simulate_outputs, simulate_flat
  use mlid_monte_carlo, only: monte_carlo, mc_statistics
  use mlid_setup, only: setup
  use mlid_inputs, only: input_signal
  use mlid_deck, only: deck_read, corrected_writable
  use mlid_handles, only: session_t, handle_new, handle_session, handle_free
  use mlid_case, only: case_t, NAMELEN, NCONDITION, CONDITION_NAMES
  use mlid_text, only: join_lines, split_lines, name_lines, joined
  use mlid_sixdof, only: sixdof_parts, SIXDOF_CONSTANTS
  use mlid_flightpath, only: flightpath_text, flightpath_corrected, FLIGHTPATH_CONSTANTS, &
                             FLIGHTPATH_CORRECTIONS, FLIGHTPATH_OUTPUTS, FLIGHTPATH_INPUTS
  use mlid_record, only: record_text
  use mlid_sampling, only: record_check_segments, record_common_step
  use mlid_equations, only: equations_t, equations_create
  use mlid_files, only: temporary_for, write_whole
  use mlid_channels, only: channels_t, channel_set_t, channels_spec, channels_read, &
                           channels_table
  use mlid_units, only: UNITLEN
  use mlid_report, only: fit_summary_t, fit_report, fit_json, case_json, validation_report, &
                         validation_json
  use mlid_validate, only: prediction_stats
  use mlid_aero_long, only: REGRESSOR_NAMES, CONSTANT_NAMES
  use mlid_param_units, only: param_units
  use mlid_layout, only: layout_table_t, layout_of, element_name, default_label, manoeuvre_map
  use mlid_jacobian_check, only: check_jacobians
  use mlid_design, only: design_t, design_create, operator_mu, riccati_length, &
                         transition_length, costate_input, input_information, mu_for_length, &
                         amplitude_limited_input, equalised_input
  use mlid_design, only: design_state_penalty, input_response, RICCATI_BRACKET
  use mlid_jobs, only: job_run, JOB_RUNS
  use mlid_run, only: corrected_record
  use mlid_fourier, only: fourier_transform
  use mlid_frequency, only: freq_record, freq_likelihood, freq_grid
  use mlid_recursive_fd, only: recursive_fdee
  use mlid_fft, only: fft_length
  use mlid_freq_response, only: welch_spectra, response_from_spectra, model_response, response_bands, &
                                unwrap_deg, DB, DEG
  use mlid_transfer_fit, only: tf_size, tf_start, tf_fit, tf_residuals, tf_log_response, &
                               coherence_weight
  implicit none
  private
  public :: mlid_design_response
  public :: mlid_handle_new, mlid_handle_free
  public :: mlid_input_signal, mlid_default_options, mlid_model_sizes, &
            mlid_option_info, mlid_option_set, mlid_option_get, mlid_options_check, &
            mlid_stop_reason, mlid_fit_outcome, mlid_deck_open, mlid_deck_case, mlid_deck_case_model, &
            mlid_deck_case_condition, mlid_condition_names, &
            mlid_deck_case_data, mlid_report_fit, mlid_case_json, &
            mlid_layout_size, mlid_layout, mlid_name_list, mlid_manoeuvre_map, &
            mlid_deck_case_record, mlid_deck_case_table, mlid_channels_read, &
            mlid_channels_table, mlid_channels_get, mlid_check_time, mlid_parameter_units, &
            mlid_deck_case_holdout, mlid_deck_case_initial_states, mlid_prediction_stats, mlid_report_validation, &
            mlid_deck_case_ties, mlid_tie_parse, mlid_sixdof_text, mlid_sixdof_constants, &
            mlid_flightpath_lists, mlid_flightpath_model_text, mlid_flightpath_corrected, &
            mlid_deck_case_corrected, mlid_deck_case_corrected_writable, &
            mlid_check_jacobians, mlid_fit, mlid_evaluate, mlid_simulate, mlid_monte_carlo, &
            mlid_monte_carlo_summary, &
            mlid_colored_cov, mlid_colored_cov_rvv, &
            mlid_design_mu, mlid_design_length, mlid_design_input, mlid_design_information, &
            mlid_design_mu_for_length, mlid_design_amplitude, mlid_design_equalised, &
            mlid_deck_case_run, mlid_fourier_transform, mlid_freq_evaluate, &
            mlid_recursive_fdee, mlid_uniform_step
  public :: mlid_freq_count, mlid_freq_response, mlid_model_freq_response, mlid_tf_fit, &
            mlid_tf_residuals, mlid_tf_response

contains

  !> The finite Fourier transform (mlid_fourier) of the channels x(nch, n)
  !> sampled at t0, t0 + dt, ... at the frequencies w(nw) (rad/s): the
  !> integral of their piecewise-linear interpolant times exp(-i w t),
  !> real and imaginary parts (nch, nw).
  subroutine mlid_fourier_transform(nch, n, x, dt, t0, nw, w, xre, xim, status, msg)
    integer(c_int), intent(in) :: nch, n, nw
    real(c_double), intent(in) :: x(nch, n), dt, t0, w(nw)
    real(c_double), intent(out) :: xre(nch, nw), xim(nch, nw)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    complex(wp) :: xf(nch, nw)
    xre = 0.0_wp
    xim = 0.0_wp
    status = MLID_ERR_INPUT
    if (n < 2) then
      msg = 'a record to transform needs at least two samples'
    else if (.not. (dt > 0.0_wp .and. ieee_is_finite(dt) .and. ieee_is_finite(t0))) then
      msg = 'the sample interval must be positive and finite'
    else if (.not. (all(ieee_is_finite(x)) .and. all(ieee_is_finite(w)))) then
      msg = 'samples and frequencies must be finite'
    else
      call fourier_transform(x, dt, t0, w, xf)
      xre = real(xf, wp)
      xim = aimag(xf)
      status = MLID_OK
      msg = ''
    end if
  end subroutine mlid_fourier_transform

  !> The one sample step dt of a record whose nseg manoeuvres start at
  !> samples segstart: each uniformly sampled and all at one step
  !> (mlid_record's record_common_step, the check of every frequency-domain
  !> tool), else the message why not.
  subroutine mlid_uniform_step(nt, t, nseg, segstart, dt, status, msg)
    integer(c_int), intent(in) :: nt, nseg, segstart(nseg)
    real(c_double), intent(in) :: t(nt)
    real(c_double), intent(out) :: dt
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call record_common_step(t, segstart, dt, status, msg)
  end subroutine mlid_uniform_step

  !> The band of the frequency-domain methods (rad/s), checked as their
  !> options are (mlid_options' band_check): n_freq frequencies from f_min
  !> to f_max Hz (mlid_frequency's freq_grid).
  subroutine band_omega(n_freq, f_min, f_max, w, status, msg)
    integer(c_int), intent(in) :: n_freq
    real(c_double), intent(in) :: f_min, f_max
    real(wp), allocatable, intent(out) :: w(:)
    integer(c_int), intent(out) :: status
    character(len=*), intent(out) :: msg
    type(options_t) :: opt
    integer :: iopt(NOPT)
    real(wp) :: ropt(NOPT)
    opt%method = METHOD_FREQ_EE
    opt%n_freq = n_freq
    opt%f_min = f_min
    opt%f_max = f_max
    call options_to_flat(opt, iopt, ropt)
    call options_from_flat(iopt, ropt, opt, status, msg)
    if (status == MLID_OK) then
      w = 8.0_wp*atan(1.0_wp)*freq_grid(opt)
    else
      allocate (w(0))
    end if
  end subroutine band_omega

  !> Recursive frequency-domain equation error (mlid_recursive_fd) over a
  !> moving window of `window` samples, one fit every `stride`: the measured
  !> states x(nx, nt), inputs u(nu, nt), F0 and G0 with the free entries
  !> marked (freef, freeg: 1 free), the band n_freq, f_min, f_max (Hz; the
  !> frequency-domain methods' band, checked as theirs); est and sig
  !> (np, nwin) the free entries (F column by column, then G) per window,
  !> tend(nwin) each window's last time.
  subroutine mlid_recursive_fdee(nx, nu, nt, t, x, u, f0, g0, freef, freeg, n_freq, f_min, f_max, &
                                 window, stride, nwin, np, tend, est, sig, status, msg)
    integer(c_int), intent(in) :: nx, nu, nt, n_freq, window, stride, nwin, np
    real(c_double), intent(in) :: t(nt), x(nx, nt), u(nu, nt), f0(nx, nx), g0(nx, nu), f_min, f_max
    integer(c_int), intent(in) :: freef(nx, nx), freeg(nx, nu)
    real(c_double), intent(out) :: tend(nwin), est(np, nwin), sig(np, nwin)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    real(wp), allocatable :: w(:)
    tend = 0.0_wp
    est = 0.0_wp
    sig = 0.0_wp
    call band_omega(n_freq, f_min, f_max, w, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (np /= count(freef == 1) + count(freeg == 1) .or. np == 0) then
      msg = 'np must count the free entries of F and G (at least one)'
    else if (.not. (all(ieee_is_finite(t)) .and. all(ieee_is_finite(x)) .and. &
                    all(ieee_is_finite(u)))) then
      msg = 'time, states and inputs must be finite'
    else
      call recursive_fdee(t, x, u, f0, g0, freef == 1, freeg == 1, w, window, stride, tend, est, &
                          sig, status, msg)
    end if
  end subroutine mlid_recursive_fdee

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

  !> A new handle (mlid_handles): what the calls below keep between them,
  !> a deck's cases or the channels last read, for this caller alone.
  subroutine mlid_handle_new(h, status, msg)
    integer(c_int64_t), intent(out) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call handle_new(h, status, msg)
  end subroutine mlid_handle_new

  !> Free handle h (0 after; 0 is freed as nothing).
  subroutine mlid_handle_free(h)
    integer(c_int64_t), intent(inout) :: h
    call handle_free(h)
  end subroutine mlid_handle_free

  !> Read a deck with the core's reader into handle h, for the calls below
  !> (sizes first, then arrays).  status /= 0: the deck as a whole cannot be
  !> used; a case that cannot run carries its own status.
  subroutine mlid_deck_open(h, path, ncases, status, msg)
    integer(c_int64_t), intent(in) :: h
    character(len=*), intent(in) :: path
    integer(c_int), intent(out) :: ncases, status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    ncases = 0
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call deck_read(path, s%cases, status, msg)
    if (allocated(s%runs)) deallocate (s%runs)
    ncases = size(s%cases)
  end subroutine mlid_deck_open

  !> Case k of handle h's deck: where it is, what it does, its sizes.
  !> nt is the number of samples of a simulate case; nfile the data files of
  !> an estimate case.
  subroutine mlid_deck_case(h, k, line, title, job, cstatus, cmsg, mkind, nx, nu, ny, nw, nth, nf, &
                            nic, nrc, nfile, nt)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    integer(c_int), intent(out) :: line, cstatus, mkind, nx, nu, ny, nw, nth, nf, nic, nrc, &
                                   nfile, nt
    character(len=128), intent(out) :: title
    character(len=16), intent(out) :: job
    character(len=256), intent(out) :: cmsg
    type(case_t), pointer :: c

    line = 0
    title = ''
    job = ''
    cstatus = MLID_ERR_INPUT
    cmsg = 'no such case'
    mkind = 0
    nx = 0
    nu = 0
    ny = 0
    nw = 0
    nth = 0
    nf = 0
    nic = 0
    nrc = 0
    nfile = 0
    nt = 0
    c => case_at(h, k)
    if (.not. associated(c)) return
    line = c%line
    title = c%title
    job = c%job
    cstatus = c%status
    cmsg = c%msg
    if (c%status /= MLID_OK) return
    mkind = c%mkind
    nx = c%nx
    nu = c%nu
    ny = c%ny
    nw = c%nw
    nth = size(c%theta)
    nf = count(c%isfree == 1)
    nic = size(c%iconst)
    nrc = size(c%rconst)
    if (allocated(c%data_files)) nfile = size(c%data_files)
    if (c%job == 'simulate' .and. len_trim(c%input_file) == 0) nt = nint(c%t_end/c%dt) + 1
  end subroutine mlid_deck_case

  !> The numeric flight-condition items of &case (mlid_case), comma-separated.
  subroutine mlid_condition_names(names)
    character(len=128), intent(out) :: names
    names = joined(CONDITION_NAMES)
  end subroutine mlid_condition_names

  !> The flight condition of case k (&case): the n numeric items in the
  !> order of mlid_condition_names (given(i) = 0 where the deck gives none),
  !> config and tags.
  subroutine mlid_deck_case_condition(h, k, n, values, given, config, tags)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, n
    real(c_double), intent(out) :: values(n)
    integer(c_int), intent(out) :: given(n)
    character(len=64), intent(out) :: config
    character(len=256), intent(out) :: tags
    type(case_t), pointer :: c
    integer :: m

    values = 0.0_c_double
    given = 0
    config = ''
    tags = ''
    c => case_at(h, k)
    if (.not. associated(c)) return
    m = min(n, NCONDITION)
    values(:m) = c%condition(:m)
    given(:m) = merge(1, 0, c%condition_given(:m))
    config = c%config
    tags = c%tags
  end subroutine mlid_deck_case_condition

  !> The model, options, prior and bounds of case k (sizes from
  !> mlid_deck_case); labels of the free parameters, one per line.
  subroutine mlid_deck_case_model(h, k, nth, nf, nic, nrc, theta, isfree, iconst, rconst, &
                                  iopt, ropt, labels, use_prior, prior, pweight, use_bounds, &
                                  lower, upper)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, nth, nf, nic, nrc
    real(c_double), intent(out) :: theta(nth), rconst(nrc), ropt(16), prior(nth), pweight(nf, nf)
    real(c_double), intent(out) :: lower(nth), upper(nth)
    integer(c_int), intent(out) :: isfree(nth), iconst(nic), iopt(16), use_prior, &
                                   use_bounds
    character(len=8192), intent(out) :: labels
    type(case_t), pointer :: c

    c => case_at(h, k)
    if (.not. associated(c)) return
    theta = c%theta
    isfree = c%isfree
    iconst = c%iconst
    rconst = c%rconst
    iopt = c%iopt
    ropt = c%ropt
    labels = join_lines(c%labels)
    use_prior = c%use_prior
    use_bounds = c%use_bounds
    prior = theta
    pweight = 0.0_wp
    lower = -huge(1.0_wp)
    upper = huge(1.0_wp)
    if (allocated(c%prior)) prior = c%prior
    if (allocated(c%pweight)) pweight = c%pweight
    if (allocated(c%lower)) lower = c%lower
    if (allocated(c%upper)) upper = c%upper
  end subroutine mlid_deck_case_model

  !> Data file j of estimate case k (its path resolved from the deck's
  !> folder), and the deck's channel names (&model input_names, output_names).
  subroutine mlid_deck_case_data(h, k, j, path, input_names, output_names)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, j
    character(len=512), intent(out) :: path
    character(len=4096), intent(out) :: input_names, output_names
    type(case_t), pointer :: c
    c => case_at(h, k)
    if (.not. associated(c)) return
    input_names = join_lines(c%input_names)
    output_names = join_lines(c%output_names)
    path = ''
    if (allocated(c%data_files)) path = c%data_files(j)
  end subroutine mlid_deck_case_data

  !> The ties of case k: n terms (to, from, scale; nmax at most) and the
  !> offset of every entry.
  subroutine mlid_deck_case_ties(h, k, nth, nmax, n, to, from, scale, offset)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, nth, nmax
    integer(c_int), intent(out) :: n, to(nmax), from(nmax)
    real(c_double), intent(out) :: scale(nmax), offset(nth)
    type(case_t), pointer :: c
    c => case_at(h, k)
    if (.not. associated(c)) return
    n = min(size(c%tie%to), nmax)
    to = 0
    from = 0
    scale = 0.0_wp
    to(1:n) = c%tie%to(1:n)
    from(1:n) = c%tie%from(1:n)
    scale(1:n) = c%tie%scale(1:n)
    offset = c%tie%offset
  end subroutine mlid_deck_case_ties

  !> A tie written as text (mlid_ties) for a model: the tied entry, its
  !> constant and its terms (n of them, at most 16).
  subroutine mlid_tie_parse(mkind, nx, nu, ny, nw, nic, iconst, nrc, rconst, text, to, offset, &
                            n, from, scale, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nic, nrc, iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    character(len=*), intent(in) :: text
    integer(c_int), intent(out) :: to, n, from(16), status
    real(c_double), intent(out) :: offset, scale(16)
    character(len=256), intent(out) :: msg
    type(layout_table_t) :: lt
    to = 0
    n = 0
    from = 0
    offset = 0.0_wp
    scale = 0.0_wp
    call layout_of(mkind, nx, nu, ny, nw, iconst, rconst, lt, status, msg)
    if (status == MLID_OK) call tie_parse(lt, text, to, offset, n, from, scale, status, msg)
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
  !> (mlid_flightpath's flightpath_corrected): the model by its text
  !> (iconst), its corrections p, the manoeuvre's output biases and delays
  !> and input delays, its record (t, u, y) -> uc, yc; when path is not
  !> blank, also written there whole or not at all (mlid_record's
  !> record_text: the channels' names and units one a line, inputs then
  !> outputs).
  subroutine mlid_flightpath_corrected(nic, iconst, np, p, ny, bias, delay, nu, udelay, nt, t, u, &
                                       y, names, units, path, uc, yc, status, msg)
    integer(c_int), intent(in) :: nic, iconst(nic), np, ny, nu, nt
    real(c_double), intent(in) :: p(np), bias(ny), delay(ny), udelay(nu), t(nt), u(nu, nt), &
                                  y(ny, nt)
    character(len=*), intent(in) :: names, units, path
    real(c_double), intent(out) :: uc(nu, nt), yc(ny, nt)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call corrected_record(iconst, p, bias, delay, udelay, t, u, y, split_lines(names, nu + ny, &
                          NAMELEN), split_lines(units, nu + ny, NAMELEN), path, uc, yc, status, msg)
  end subroutine mlid_flightpath_corrected

  !> Whether every corrected record of case k can be written (mlid_deck's
  !> corrected_writable): one line naming the path if not.
  subroutine mlid_deck_case_corrected_writable(h, k, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(case_t), pointer :: c
    c => case_at(h, k)
    call no_case(c, status, msg)
    if (status == MLID_OK) call corrected_writable(c, status, msg)
  end subroutine mlid_deck_case_corrected_writable

  !> Where estimate case k writes manoeuvre j's corrected record (blank: nowhere).
  subroutine mlid_deck_case_corrected(h, k, j, path)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, j
    character(len=512), intent(out) :: path
    type(case_t), pointer :: c
    path = ''
    c => case_at(h, k)
    if (.not. associated(c)) return
    if (allocated(c%corrected)) then
      if (j >= 1 .and. j <= size(c%corrected)) path = c%corrected(j)
    end if
  end subroutine mlid_deck_case_corrected

  !> The files validate case k predicts (numbers into its file list).
  subroutine mlid_deck_case_holdout(h, k, nmax, n, holdout)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, nmax
    integer(c_int), intent(out) :: n, holdout(nmax)
    type(case_t), pointer :: c
    holdout = 0
    n = 0
    c => case_at(h, k)
    if (.not. associated(c)) return
    if (allocated(c%holdout)) n = min(size(c%holdout), nmax)
    if (n > 0) holdout(1:n) = c%holdout(1:n)
  end subroutine mlid_deck_case_holdout

  !> The initial states case k gives per manoeuvre (n = 0: none; else nx per
  !> data file, manoeuvre after manoeuvre).
  subroutine mlid_deck_case_initial_states(h, k, nmax, n, x0)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, nmax
    integer(c_int), intent(out) :: n
    real(c_double), intent(out) :: x0(nmax)
    type(case_t), pointer :: c
    x0 = 0.0_wp
    n = 0
    c => case_at(h, k)
    if (.not. associated(c)) return
    if (allocated(c%initial_states)) n = min(size(c%initial_states), nmax)
    if (n > 0) x0(1:n) = c%initial_states(1:n)
  end subroutine mlid_deck_case_initial_states

  !> Read data file j of estimate case k as the case takes it (channels,
  !> units, derived channels, units shown, window) and keep it for
  !> mlid_channels_get; a warning as mlid_channels_read gives it.
  subroutine mlid_deck_case_record(h, k, j, nt, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, j
    integer(c_int), intent(out) :: nt, status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(case_t), pointer :: c
    nt = 0
    if (.not. has_file(h, k, j, s, c, status, msg)) return
    call channels_read(c%data_files(j), c%chan, c%win_start(j), c%win_end(j), s%taken, status, &
                       msg, manoeuvre=c%file_no(j))
    nt = taken_samples(s%taken, status)
  end subroutine mlid_deck_case_record

  !> Whether case k of handle h (its session s, the case c) has a data
  !> file j (a simulate case has none).
  logical function has_file(h, k, j, s, c, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, j
    type(session_t), pointer, intent(out) :: s
    type(case_t), pointer, intent(out) :: c
    integer(c_int), intent(out) :: status
    character(len=*), intent(out) :: msg
    has_file = .false.
    c => null()
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    c => case_at(h, k)
    call no_case(c, status, msg)
    if (status /= MLID_OK) return
    if (allocated(c%data_files)) has_file = j >= 1 .and. j <= size(c%data_files)
    if (has_file) return
    status = MLID_ERR_INPUT
    write (msg, '(a,i0,a,i0)') 'case ', k, ' has no data file ', j
  end function has_file

  !> The same for a table the Python front end read from data file j of
  !> case k (.mat or HDF5): x(nrow, ncol) with its columns' names and units
  !> one per line (blank where unknown).
  subroutine mlid_deck_case_table(h, k, j, nrow, ncol, x, names, units, nt, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, j, nrow, ncol
    real(c_double), intent(in) :: x(nrow, ncol)
    character(len=*), intent(in) :: names, units
    integer(c_int), intent(out) :: nt, status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(case_t), pointer :: c
    nt = 0
    if (.not. has_file(h, k, j, s, c, status, msg)) return
    call channels_table(c%data_files(j), x, split_lines(names, ncol, NAMELEN), &
                        split_lines(units, ncol, UNITLEN), c%chan, c%win_start(j), c%win_end(j), &
                        s%taken, status, msg, manoeuvre=c%file_no(j))
    nt = taken_samples(s%taken, status)
  end subroutine mlid_deck_case_table

  !> Read a text record's channels (mlid_channels) and keep them for
  !> mlid_channels_get.  The spec as channels_spec takes it: one entry per
  !> line; t_start, t_end: the window.  Status OK with msg 'warning: ...'
  !> when a channel looks wrong for its declared unit (degrees in rad).
  subroutine mlid_channels_read(h, path, time, inputs, outputs, columns, units, derived, show, &
                                skip_rows, t_start, t_end, dt, nt, status, msg)
    integer(c_int64_t), intent(in) :: h
    character(len=*), intent(in) :: path, time, inputs, outputs, columns, units, derived, show
    integer(c_int), intent(in) :: skip_rows
    real(c_double), intent(in) :: t_start, t_end, dt
    integer(c_int), intent(out) :: nt, status
    character(len=256), intent(out) :: msg
    type(channels_t) :: spec
    type(session_t), pointer :: s
    nt = 0
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call channels_spec(time, inputs, outputs, columns, units, derived, show, skip_rows, spec, &
                       status, msg)
    spec%dt = dt
    if (status == MLID_OK) then
      call channels_read(path, spec, t_start, t_end, s%taken, status, msg)
    else
      msg = 'data file '//trim(path)//': '//trim(msg)
    end if
    nt = taken_samples(s%taken, status)
  end subroutine mlid_channels_read

  !> The same for a table x(nrow, ncol) the Python front end read (source
  !> names it in messages), with its columns' names and units one per line.
  subroutine mlid_channels_table(h, source, nrow, ncol, x, names, col_units, time, inputs, &
                                 outputs, columns, units, derived, show, t_start, t_end, dt, &
                                 nt, status, msg)
    integer(c_int64_t), intent(in) :: h
    character(len=*), intent(in) :: source, names, col_units, time, inputs, outputs, columns, &
                                    units, derived, show
    integer(c_int), intent(in) :: nrow, ncol
    real(c_double), intent(in) :: x(nrow, ncol), t_start, t_end, dt
    integer(c_int), intent(out) :: nt, status
    character(len=256), intent(out) :: msg
    type(channels_t) :: spec
    type(session_t), pointer :: s
    nt = 0
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call channels_spec(time, inputs, outputs, columns, units, derived, show, 0, spec, status, &
                       msg)
    spec%dt = dt
    if (status == MLID_OK) then
      call channels_table(source, x, split_lines(names, ncol, NAMELEN), &
                          split_lines(col_units, ncol, UNITLEN), spec, t_start, t_end, s%taken, &
                          status, msg)
    else
      msg = 'data '//trim(source)//': '//trim(msg)
    end if
    nt = taken_samples(s%taken, status)
  end subroutine mlid_channels_table

  !> The channels handle h took last: t(nt), u(nu, nt), y(ny, nt), the
  !> file line (or table row) of each sample; per channel (inputs, then
  !> outputs) the name, the core's unit and the unit declared one per line,
  !> and scale and offset: core = scale*declared + offset.  Sizes other
  !> than those taken give zeros and blanks.
  subroutine mlid_channels_get(h, nu, ny, nt, t, u, y, line, names, units, shown, scale, offset)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: nu, ny, nt
    real(c_double), intent(out) :: t(nt), u(nu, nt), y(ny, nt), scale(nu + ny), offset(nu + ny)
    integer(c_int), intent(out) :: line(nt)
    character(len=65536), intent(out) :: names, units, shown
    type(session_t), pointer :: s
    integer :: status
    character(len=64) :: msg
    t = 0.0_wp
    u = 0.0_wp
    y = 0.0_wp
    line = 0
    names = ''
    units = ''
    shown = ''
    scale = 0.0_wp
    offset = 0.0_wp
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    if (.not. allocated(s%taken%t)) return
    if (size(s%taken%t) /= nt .or. size(s%taken%u, 1) /= nu .or. size(s%taken%y, 1) /= ny) return
    t = s%taken%t
    u = s%taken%u
    y = s%taken%y
    line = s%taken%line
    names = join_lines(s%taken%names)
    units = join_lines(s%taken%units)
    shown = join_lines(s%taken%shown)
    scale = s%taken%scale
    offset = s%taken%offset
  end subroutine mlid_channels_get

  !> Samples of the set taken (0 when it could not be).
  integer function taken_samples(taken, status) result(nt)
    type(channel_set_t), intent(in) :: taken
    integer, intent(in) :: status
    nt = 0
    if (status == MLID_OK) nt = size(taken%t)
  end function taken_samples

  !> Case k of the deck in handle h; null when there is none.
  function case_at(h, k) result(c)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    type(case_t), pointer :: c
    type(session_t), pointer :: s
    integer :: status
    character(len=64) :: msg
    c => null()
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    if (.not. allocated(s%cases)) return
    if (k < 1 .or. k > size(s%cases)) return
    c => s%cases(k)
  end function case_at

  !> 'no such case' when c is null.
  subroutine no_case(c, status, msg)
    type(case_t), pointer, intent(in) :: c
    integer(c_int), intent(out) :: status
    character(len=*), intent(out) :: msg
    status = MLID_OK
    msg = ''
    if (associated(c)) return
    status = MLID_ERR_INPUT
    msg = 'no such case (or not a live handle)'
  end subroutine no_case

  !> The printed report and the JSON object of a fit (the text mlid-batch
  !> prints and writes); labels one per line; the text ends where its
  !> length says.
  !> sigc: sigma corrected for coloured residuals, lag: its lag.
  subroutine mlid_report_fit(nf, ny, nh, labels, units, iopt, ropt, start, est, sig, sigc, lag, cov, eigval, &
                             eigvec, rhat, hist, cost, niter, reason, converged, nrank, title, job, &
                             status, msg, rnoise, report, nreport, json, njson)
    integer(c_int), intent(in) :: nf, ny, nh, iopt(16), niter, reason, converged, nrank, status, lag
    real(c_double), intent(in) :: ropt(16)
    character(len=*), intent(in) :: labels, units, title, job, msg
    real(c_double), intent(in) :: start(nf), est(nf), sig(nf), sigc(nf), cov(nf, nf), eigval(nf), &
                                  eigvec(nf, nf), rhat(ny, ny), hist(nh), cost
    real(c_double), intent(in) :: rnoise(ny)   !< the innovations criterion's R; NaN: none
    character(len=262144), intent(out) :: report, json
    integer(c_int), intent(out) :: nreport, njson
    type(fit_summary_t) :: s
    character(len=:), allocatable :: text

    s = fit_summary_t(split_lines(labels, nf, NAMELEN), start, est, sig, sigc, cov, eigval, eigvec, &
                      rhat, hist, cost, niter, reason, nrank, lag, converged == 1, &
                      split_lines(units, nf, UNITLEN))
    if (all(ieee_is_finite(rnoise))) s%rnoise = rnoise
    text = fit_report(s, iopt, ropt, status, msg)
    nreport = min(len(text), len(report))
    report = text
    text = fit_json(title, job, status, msg, s, iopt, ropt)
    njson = min(len(text), len(json))
    json = text
  end subroutine mlid_report_fit

  !> The JSON object of a case without a fit (samples >= 0: a simulate
  !> case that wrote out).
  subroutine mlid_case_json(title, job, status, msg, samples, out, json, njson)
    character(len=*), intent(in) :: title, job, msg, out
    integer(c_int), intent(in) :: status, samples
    character(len=4096), intent(out) :: json
    integer(c_int), intent(out) :: njson
    character(len=:), allocatable :: text
    if (samples >= 0) then
      text = case_json(title, job, status, msg, samples, out)
    else
      text = case_json(title, job, status, msg)
    end if
    njson = min(len(text), len(json))
    json = text
  end subroutine mlid_case_json

  !> Sizes of a model's parameter layout (mlid_layout): blocks and entries.
  subroutine mlid_layout_size(mkind, nx, nu, ny, nw, nic, iconst, nrc, rconst, nblock, nth, &
                              status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nic, nrc, iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    integer(c_int), intent(out) :: nblock, nth, status
    character(len=256), intent(out) :: msg
    type(layout_table_t) :: lt
    call layout_of(mkind, nx, nu, ny, nw, iconst, rconst, lt, status, msg)
    nblock = lt%nblock
    nth = lt%nth
  end subroutine mlid_layout_size

  !> A model's parameter layout: each block's key (one per line), rows,
  !> columns (-1: a vector) and offset in theta; each entry's element name
  !> and default label (one per line).
  subroutine mlid_layout(mkind, nx, nu, ny, nw, nic, iconst, nrc, rconst, nblock, nth, keys, &
                         rows, cols, offs, names, labels, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nic, nrc, iconst(nic), nblock, nth
    real(c_double), intent(in) :: rconst(nrc)
    character(len=256), intent(out) :: keys
    integer(c_int), intent(out) :: rows(nblock), cols(nblock), offs(nblock), status
    character(len=131072), intent(out) :: names, labels
    character(len=256), intent(out) :: msg
    type(layout_table_t) :: lt
    character(len=:), allocatable :: text
    integer :: k

    keys = ''
    names = ''
    labels = ''
    rows = 0
    cols = 0
    offs = 0
    call layout_of(mkind, nx, nu, ny, nw, iconst, rconst, lt, status, msg)
    if (status /= MLID_OK) return
    if (lt%nblock /= nblock .or. lt%nth /= nth) then
      status = MLID_ERR_INPUT
      msg = 'layout sizes do not match mlid_layout_size'
      return
    end if
    rows = lt%rows(1:nblock)
    cols = lt%cols(1:nblock)
    offs = lt%off(1:nblock)
    text = ''
    do k = 1, nblock
      text = text//trim(lt%key(k))//achar(10)
    end do
    keys = text
    text = ''
    do k = 1, nth
      text = text//trim(element_name(lt, k))//achar(10)
    end do
    names = text
    text = ''
    do k = 1, nth
      text = text//trim(default_label(lt, k))//achar(10)
    end do
    labels = text
  end subroutine mlid_layout

  !> theta of a model for nseg manoeuvres (mlid_layout's manoeuvre_map):
  !> entry k (k <= n) copies entry map(k) of the one-manoeuvre theta and
  !> belongs to manoeuvre seg(k), 0 if shared; nmax >= nseg*nth.
  subroutine mlid_manoeuvre_map(mkind, nx, nu, ny, nw, nic, iconst, nrc, rconst, nseg, nmax, &
                                n, map, seg, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nic, nrc, iconst(nic), nseg, nmax
    real(c_double), intent(in) :: rconst(nrc)
    integer(c_int), intent(out) :: n, map(nmax), seg(nmax), status
    character(len=256), intent(out) :: msg
    type(layout_table_t) :: lt
    integer, allocatable :: m(:), s(:)
    n = 0
    map = 0
    seg = 0
    call layout_of(mkind, nx, nu, ny, nw, iconst, rconst, lt, status, msg)
    if (status /= MLID_OK) return
    call manoeuvre_map(lt, max(nseg, 1), m, s)
    if (size(m) > nmax) then
      status = MLID_ERR_INPUT
      msg = 'manoeuvre map: nmax too small'
      return
    end if
    n = size(m)
    map(1:n) = m
    seg(1:n) = s
  end subroutine mlid_manoeuvre_map

  !> Theil's U, rms error and rms/sigma per output of a prediction
  !> (mlid_validate): y, yhat (ny, nt), rhat the identification's.
  subroutine mlid_prediction_stats(ny, nt, y, yhat, rhat, theil, rms, ratio)
    integer(c_int), intent(in) :: ny, nt
    real(c_double), intent(in) :: y(ny, nt), yhat(ny, nt), rhat(ny, ny)
    real(c_double), intent(out) :: theil(ny), rms(ny), ratio(ny)
    call prediction_stats(y, yhat, rhat, theil, rms, ratio)
  end subroutine mlid_prediction_stats

  !> The printed lines and the JSON member of a validation.
  subroutine mlid_report_validation(ny, nh, names, holdout, theil, rms, ratio, report, nreport, &
                                    json, njson)
    integer(c_int), intent(in) :: ny, nh, holdout(nh)
    character(len=*), intent(in) :: names
    real(c_double), intent(in) :: theil(ny), rms(ny), ratio(ny)
    character(len=65536), intent(out) :: report, json
    integer(c_int), intent(out) :: nreport, njson
    character(len=:), allocatable :: text
    text = validation_report(split_lines(names, ny, NAMELEN), holdout, theil, rms, ratio)
    nreport = min(len(text), len(report))
    report = text
    text = validation_json(split_lines(names, ny, NAMELEN), holdout, theil, rms, ratio)
    njson = min(len(text), len(json))
    json = text
  end subroutine mlid_report_validation

  !> The unit of every entry of a model's theta (mlid_param_units), one per
  !> line, from its record's channel units (one per line, core units).
  subroutine mlid_parameter_units(mkind, nx, nu, ny, nw, nic, iconst, nrc, rconst, nth, theta, &
                              input_units, output_units, units, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nic, nrc, iconst(nic), nth
    real(c_double), intent(in) :: rconst(nrc), theta(nth)
    character(len=*), intent(in) :: input_units, output_units
    character(len=65536), intent(out) :: units
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(layout_table_t) :: lt
    character(len=UNITLEN), allocatable :: each(:)
    units = ''
    allocate (each(nth))
    call layout_of(mkind, nx, nu, ny, nw, iconst, rconst, lt, status, msg)
    if (status /= MLID_OK) return
    call param_units(lt, theta, split_lines(input_units, nu, UNITLEN), &
                     split_lines(output_units, ny, UNITLEN), each)
    units = join_lines(each)
  end subroutine mlid_parameter_units

  !> Time increasing and without gaps (a step over 1.5 times the median),
  !> each manoeuvre of a joined record on its own (segstart: first samples).
  subroutine mlid_check_time(nt, t, nseg, segstart, status, msg)
    integer(c_int), intent(in) :: nt, nseg, segstart(nseg)
    real(c_double), intent(in) :: t(nt)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call record_check_segments(t, segstart, status, msg)
  end subroutine mlid_check_time

  !> A list of names the core defines, one per line: 'regressors' (of the
  !> longitudinal model, by code) or 'constants' (its rconst, in order).
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
    case ('core_jobs')            ! the deck jobs mlid_jobs runs whole (mlid_deck_case_run)
      text = JOB_RUNS
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

  !> Largest relative differences between the model's analytic Jacobians
  !> (df/dx, df/dp, dh/dx, dh/dp) and central differences at (x, u, p).
  subroutine mlid_check_jacobians(mkind, nx, nu, ny, nw, np, p, nic, iconst, nrc, rconst, x, u, &
                                  w, err, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, np, nic, nrc
    real(c_double), intent(in) :: p(np), x(nx), u(nu), w(nw)
    integer(c_int), intent(in) :: iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    real(c_double), intent(out) :: err(6)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    class(model_t), allocatable :: m
    real(wp) :: uw(nu + nw)

    err = 0.0_wp
    call model_create(mkind, nx, nu, ny, nw, iconst, rconst, m, status, msg)
    if (status /= MLID_OK) return
    if (m%np /= np) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0)') 'the model has ', m%np, ' parameters, not ', np
      return
    end if
    uw(1:nu) = u
    uw(nu + 1:) = w
    call check_jacobians(m, 0.0_wp, x, uw, p, err)
  end subroutine mlid_check_jacobians

  !> Maximum-likelihood fit from theta0 (output or filter error, iopt(6)),
  !> with the options of report sec. 4.6: a priori values prior(nth) and weight
  !> pweight(nf, nf) over the free parameters (use_prior = 1), bounds
  !> lower(nth) <= theta <= upper(nth) (use_bounds = 1), the rank-deficient
  !> search from iopt(10) (rank: the rank of the last step).
  !> Out: theta_start (theta0, or the equation-error start-up's values), theta, sigma (Cramer-Rao, 0 for fixed), cov/info/grad/eigval over
  !> the nf free parameters, rhat (R-hat, or the mean innovation covariance),
  !> yhat, cost_hist(nc) (nc = max_iter + 1; entries past niter + 1 are 0),
  !> cost, niter, reason (mlid_kinds STOP_*), converged (0/1), bad_param
  !> (free index of a singular direction), sigma_c and cov_c (the same
  !> corrected for coloured residuals, mlid_colored) and lag (its lag).
  !> Several manoeuvres: the record holds them one after the other, segment k
  !> from sample segstart(k) (segstart(1) = 1), with an initial state and a
  !> bias vector each in theta (the x0 and bias blocks nseg times as long).
  subroutine mlid_fit(mkind, nx, nu, ny, nw, nth, theta0, isfree, ntie, mtie, tie_to, tie_from, &
                      tie_scale, tie_offset, nic, iconst, nrc, &
                      rconst, nt, t, u, y, nseg, segstart, iopt, ropt, nf, nc, use_prior, prior, &
                      pweight, use_bounds, lower, upper, theta_start, theta, sigma, cov, info, &
                      grad, eigval, eigvec, rhat, yhat, cost_hist, cost, niter, reason, converged, &
                      rank, bad_param, sigma_c, cov_c, lag, rnoise, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nth, nic, nrc, nt, nf, nc, nseg
    integer(c_int), intent(in) :: segstart(nseg)
    integer(c_int), intent(in) :: use_prior, use_bounds
    real(c_double), intent(in) :: prior(nth), pweight(nf, nf), lower(nth), upper(nth)
    real(c_double), intent(in) :: theta0(nth)
    integer(c_int), intent(in) :: isfree(nth), ntie, mtie, tie_to(mtie), tie_from(mtie)
    real(c_double), intent(in) :: tie_scale(mtie), tie_offset(nth)  !< affine ties (ntie terms)
    integer(c_int), intent(in) :: iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    real(c_double), intent(in) :: t(nt), u(nu, nt), y(ny, nt)
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16)
    real(c_double), intent(out) :: theta_start(nth), theta(nth), sigma(nth), cov(nf, nf)
    real(c_double), intent(out) :: info(nf, nf), grad(nf)
    real(c_double), intent(out) :: eigval(nf), eigvec(nf, nf), rhat(ny, ny), yhat(ny, nt)
    real(c_double), intent(out) :: cost_hist(nc), cost
    integer(c_int), intent(out) :: niter, reason, converged, rank, bad_param, status
    real(c_double), intent(out) :: sigma_c(nth), cov_c(nf, nf)
    integer(c_int), intent(out) :: lag
    !> noise_criterion = 'innovations': the R the fit left (diagonal); NaN otherwise
    real(c_double), intent(out) :: rnoise(ny)
    character(len=256), intent(out) :: msg
    type(options_t) :: opt
    type(param_map_t) :: pm
    type(fit_result_t) :: res
    type(fit_view_t) :: v
    integer :: bad

    if (nc /= iopt(1) + 1) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0)') 'cost history length ', nc, ' must be max_iter + 1 = ', &
        iopt(1) + 1
      return
    end if
    call fit_solve(mkind, nx, nu, ny, nw, theta0, isfree, &
                   ties_of(ntie, tie_to, tie_from, tie_scale, tie_offset), iconst, rconst, t, u, &
                   y, segstart, iopt, ropt, nf, use_prior, prior, pweight, use_bounds, lower, &
                   upper, res, pm, opt, bad, status, msg)
    v = fit_view(res, pm, opt, theta0, ny, nt, bad)
    theta_start = v%theta_start
    theta = v%theta
    sigma = v%sigma
    cov = 0.0_wp
    info = 0.0_wp
    grad = 0.0_wp
    eigval = 0.0_wp
    eigvec = 0.0_wp
    sigma_c = v%sigma_c
    cov_c = 0.0_wp
    if (size(v%cov, 1) == nf) then        ! a fit that got as far as its set-up
      cov = v%cov
      cov_c = v%cov_c
      info = v%info
      grad = v%grad
      eigval = v%eigval
      eigvec = v%eigvec
    end if
    rhat = v%rhat
    yhat = v%yhat
    cost_hist = 0.0_wp
    if (size(v%hist) == nc) cost_hist = v%hist
    cost = v%cost
    niter = v%niter
    reason = v%reason
    converged = merge(1, 0, v%converged)
    rank = v%rank
    bad_param = v%bad
    lag = v%lag
    rnoise = v%rnoise
  end subroutine mlid_fit

  !> The frequency-domain methods' data and fit at theta (mlid_frequency):
  !> freq(nk) the frequencies (Hz, manoeuvre after manoeuvre, nk = n_freq
  !> times the manoeuvres), z the measured left-hand sides (output error:
  !> the outputs' transforms Y; equation error: i w Y for the outputs that
  !> measure a state), zhat the model's, real and imaginary parts (ny, nk);
  !> the cost, its gradient and information over the nf free parameters and
  !> S-hat (rhat) there.
  subroutine mlid_freq_evaluate(mkind, nx, nu, ny, nw, nth, theta, isfree, ntie, mtie, tie_to, &
                                 tie_from, tie_scale, tie_offset, nic, iconst, nrc, rconst, nt, &
                                 t, u, y, nseg, segstart, iopt, ropt, nk, freq, zre, zim, &
                                 zhre, zhim, nf, cost, grad, info, rhat, nterms, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nth, nic, nrc, nt, nseg, nk, nf
    integer(c_int), intent(in) :: segstart(nseg)
    real(c_double), intent(in) :: theta(nth)
    integer(c_int), intent(in) :: isfree(nth), ntie, mtie, tie_to(mtie), tie_from(mtie)
    real(c_double), intent(in) :: tie_scale(mtie), tie_offset(nth)
    integer(c_int), intent(in) :: iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    real(c_double), intent(in) :: t(nt), u(nu, nt), y(ny, nt)
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16)
    real(c_double), intent(out) :: freq(nk), zre(ny, nk), zim(ny, nk), zhre(ny, nk), zhim(ny, nk)
    real(c_double), intent(out) :: cost, grad(nf), info(nf, nf), rhat(ny, ny)
    integer(c_int), intent(out) :: nterms      !< the transient terms estimated (mlid_frequency)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    real(wp), allocatable :: tf(:), uf(:, :), yf(:, :), yh(:, :)
    real(wp) :: th(nth)
    integer :: k

    freq = 0.0_wp
    nterms = 0
    cost = 0.0_wp
    grad = 0.0_wp
    info = 0.0_wp
    rhat = 0.0_wp
    zre = 0.0_wp
    zim = 0.0_wp
    zhre = 0.0_wp
    zhim = 0.0_wp
    call setup(mkind, nx, nu, ny, nw, theta, isfree, &
               ties_of(ntie, tie_to, tie_from, tie_scale, tie_offset), iconst, rconst, t, u, y, iopt, &
               ropt, nf, m, opt, pm, status, msg, segstart)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (.not. frequency_method(opt)) then
      msg = 'frequency residuals are for method = ''frequency_output_error'' or '// &
            '''frequency_equation_error'''
      return
    else if (nk /= opt%n_freq*nseg) then
      write (msg, '(a,i0,a,i0)') 'nk = ', nk, ' must be n_freq times the manoeuvres = ', &
        opt%n_freq*nseg
      return
    end if
    th = theta
    call apply_ties(pm%tie, th)
    call freq_record(m, th, pm, t, u, y, opt, tf, uf, yf, status, msg)
    if (status /= MLID_OK) return
    if (nf /= pm%nf) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0,a)') 'nf = ', nf, ' but ', pm%nf, ' parameters are free'
      return
    end if
    allocate (yh(ny, 2*nk))
    call freq_likelihood(m, th, pm, tf, uf, yf, opt, cost, rhat, yh, status, msg, grad, info, &
                         nterms=k)
    nterms = k
    if (status /= MLID_OK) return
    freq = reshape(spread(freq_grid(opt), 2, nseg), [nk])
    zre = yf(:, 1::2)
    zim = yf(:, 2::2)
    zhre = yh(:, 1::2)
    zhim = yh(:, 2::2)
  end subroutine mlid_freq_evaluate

  !> Cost, gradient, information matrix and output sensitivity norms at
  !> theta, without iterating.
  subroutine mlid_evaluate(mkind, nx, nu, ny, nw, nth, theta, isfree, ntie, mtie, tie_to, tie_from, &
                           tie_scale, tie_offset, nic, iconst, nrc, &
                           rconst, nt, t, u, y, nseg, segstart, iopt, ropt, nf, cost, grad, info, &
                           rhat, yhat, sens, wsens, msens, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nth, nic, nrc, nt, nf, nseg
    integer(c_int), intent(in) :: segstart(nseg)
    real(c_double), intent(in) :: theta(nth)
    integer(c_int), intent(in) :: isfree(nth), ntie, mtie, tie_to(mtie), tie_from(mtie)
    real(c_double), intent(in) :: tie_scale(mtie), tie_offset(nth)  !< affine ties (ntie terms)
    integer(c_int), intent(in) :: iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    real(c_double), intent(in) :: t(nt), u(nu, nt), y(ny, nt)
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16)
    real(c_double), intent(out) :: cost, grad(nf), info(nf, nf), rhat(ny, ny), yhat(ny, nt)
    real(c_double), intent(out) :: sens(ny, nf)
    real(c_double), intent(out) :: wsens(ny, nt, nf), msens(nf, nf)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    real(wp) :: th(nth)
    type(sens_keep_t) :: keep

    cost = 0.0_wp
    grad = 0.0_wp
    info = 0.0_wp
    rhat = 0.0_wp
    yhat = 0.0_wp
    sens = 0.0_wp
    wsens = 0.0_wp
    msens = 0.0_wp
    call setup(mkind, nx, nu, ny, nw, theta, isfree, &
               ties_of(ntie, tie_to, tie_from, tie_scale, tie_offset), iconst, rconst, t, u, y, iopt, &
               ropt, &
               nf, m, opt, pm, status, msg, segstart)
    if (status /= MLID_OK) return
    if (frequency_method(opt)) then
      status = MLID_ERR_INPUT
      msg = 'evaluate works on the time-domain record: the frequency-domain methods have '// &
            'frequency_evaluate'
      return
    end if
    th = theta
    call apply_ties(pm%tie, th)
    ! wsens made as a fit makes it at its estimate: from what the evaluation keeps
    call likelihood(m, th, pm, t, u, y, opt, cost, rhat, yhat, status, msg, grad, info, sens, &
                    msens, keep=keep)
    if (status == MLID_OK .and. allocated(keep%dy)) call weighted_sensitivities(keep, pm%l%seg, &
                                                                                wsens)
  end subroutine mlid_evaluate

  !> The covariance corrected for coloured residuals (mlid_colored) from
  !> weighted sensitivities a(ny, nt, nf), residuals v(ny, nt), the segment
  !> starts, cov (M^-1), info (M) and msens (the part of M a makes); Rvv up
  !> to lag_in (< 0: the lag chosen from v, returned in lag).
  subroutine mlid_colored_cov(ny, nt, nf, nseg, segstart, a, v, cov, info, msens, lag_in, &
                              cov_c, lag, status, msg)
    integer(c_int), intent(in) :: ny, nt, nf, nseg, segstart(nseg), lag_in
    real(c_double), intent(in) :: a(ny, nt, nf), v(ny, nt), cov(nf, nf), info(nf, nf), &
                                  msens(nf, nf)
    real(c_double), intent(out) :: cov_c(nf, nf)
    integer(c_int), intent(out) :: lag, status
    character(len=256), intent(out) :: msg
    integer :: lg
    call colored_covariance(cov, info, msens, a, v, segstart, lag_in, cov_c, lg, status, msg)
    lag = lg
  end subroutine mlid_colored_cov

  !> The same with the residual autocovariance given: rvv(:, :, k+1) =
  !> Rvv(k), k = 0 .. nlag (Bartlett weights at nlag).
  subroutine mlid_colored_cov_rvv(ny, nt, nf, nseg, segstart, a, nlag, rvv, cov, info, msens, &
                                  cov_c, status, msg)
    integer(c_int), intent(in) :: ny, nt, nf, nseg, segstart(nseg), nlag
    real(c_double), intent(in) :: a(ny, nt, nf), rvv(ny, ny, nlag + 1), cov(nf, nf), &
                                  info(nf, nf), msens(nf, nf)
    real(c_double), intent(out) :: cov_c(nf, nf)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call colored_sandwich(cov, info, msens, a, rvv, segstart, cov_c, status, msg)
  end subroutine mlid_colored_cov_rvv

  !> Outputs y and states x of the model along t with inputs u, with the
  !> process and measurement noise whose statistics are in theta (seeded).
  subroutine mlid_simulate(mkind, nx, nu, ny, nw, nth, theta, nic, iconst, nrc, rconst, nt, t, u, &
                           seed, timing, iopt, ropt, y, x, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nth, nic, nrc, nt, seed, timing
    real(c_double), intent(in) :: theta(nth)
    integer(c_int), intent(in) :: iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    real(c_double), intent(in) :: t(nt), u(nu, nt)
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16)
    real(c_double), intent(out) :: y(ny, nt), x(nx, nt)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call simulate_flat(mkind, nx, nu, ny, nw, theta, iconst, rconst, t, u, iopt, ropt, seed, y, x, &
                       status, msg, timing)
  end subroutine mlid_simulate

  !> nrun identifications: data from theta_true with seeds seed0, seed0+1, ...,
  !> each fitted from theta_start.  est and sig (nf, nrun) are the estimates
  !> and Cramer-Rao standard deviations of the free parameters, iters the
  !> iterations, run_status each run's status (0, or the code it ended on).
  subroutine mlid_monte_carlo(mkind, nx, nu, ny, nw, nth, theta_true, theta_start, isfree, &
                              ntie, mtie, tie_to, tie_from, tie_scale, tie_offset, &
                              nic, iconst, nrc, rconst, nt, t, u, seed0, nrun, iopt, ropt, nf, &
                              est, sig, info, iters, run_status, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nth, nic, nrc, nt, seed0, nrun, nf
    real(c_double), intent(in) :: theta_true(nth), theta_start(nth)
    integer(c_int), intent(in) :: isfree(nth), ntie, mtie, tie_to(mtie), tie_from(mtie)
    real(c_double), intent(in) :: tie_scale(mtie), tie_offset(nth)  !< affine ties (ntie terms)
    integer(c_int), intent(in) :: iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    real(c_double), intent(in) :: t(nt), u(nu, nt)
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16)
    real(c_double), intent(out) :: est(nf, nrun), sig(nf, nrun), info(nf, nf, nrun)
    integer(c_int), intent(out) :: iters(nrun), run_status(nrun), status
    character(len=256), intent(out) :: msg
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    real(wp) :: yzero(ny, nt)

    est = 0.0_wp
    info = 0.0_wp
    sig = 0.0_wp
    iters = 0
    run_status = 0
    yzero = 0.0_wp
    call setup(mkind, nx, nu, ny, nw, theta_start, isfree, &
               ties_of(ntie, tie_to, tie_from, tie_scale, tie_offset), iconst, rconst, t, u, yzero, &
               iopt, ropt, nf, m, opt, pm, status, msg)
    if (status /= MLID_OK) return
    if (.not. all(ieee_is_finite(theta_true))) then
      status = MLID_ERR_INPUT
      msg = 'true parameter values must be finite'
      return
    end if
    call monte_carlo(m, theta_true, theta_start, pm, t, u, opt, seed0, est, sig, iters, run_status, &
                     info)
  end subroutine mlid_monte_carlo

  !> The statistics of Monte Carlo runs (mlid_monte_carlo's mc_statistics,
  !> those of the deck job too) over the runs with run_status 0 (nok):
  !> mean, sample sigma and mean Cramer-Rao sigma of each free parameter
  !> (nf), and stats = [trace, det of the sample covariance, trace, det of
  !> the mean information]; NaN where too few runs.
  subroutine mlid_monte_carlo_summary(nf, nrun, est, sig, info, run_status, nok, mean, &
                                      sample_sigma, cr_sigma, stats)
    integer(c_int), intent(in) :: nf, nrun
    real(c_double), intent(in) :: est(nf, nrun), sig(nf, nrun), info(nf, nf, nrun)
    integer(c_int), intent(in) :: run_status(nrun)
    integer(c_int), intent(out) :: nok
    real(c_double), intent(out) :: mean(nf), sample_sigma(nf), cr_sigma(nf), stats(4)
    integer :: n
    call mc_statistics(est, sig, info, run_status, n, mean, sample_sigma, cr_sigma, stats(1), &
                       stats(2), stats(3), stats(4))
    nok = n
  end subroutine mlid_monte_carlo_summary

  !> Input design (mlid_design).  Common arguments: the linear model F(nx,nx),
  !> G(nx,nu), H(ny,nx), the noise spectral density R(ny,ny), the process
  !> noise Gamma Q Gamma' gq(nx,nx) (zero: none), the m unknowns
  !> by block ukind (1 F, 2 G, 3 H), row urow and column ucol, weights w(m).
  !> mu_max on [0, T] by the operator method on ncell and 2 ncell cells; u:
  !> the optimal input on the 2 ncell cells (unit energy, nu per cell).
  !> kx(nx,nx), symmetric >= 0, the state-limit penalty of report 7.6 (mu the
  !> largest eigenvalue of tr(WM) - int x' K x dt); zero for none.
  subroutine mlid_design_mu(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w, kx, t, ncell, mu, &
                            u, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, ncell
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), w(m), &
                                  kx(nx, nx), t
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: mu, u(2*ncell*nu)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    mu = 0.0_wp
    u = 0.0_wp
    call design_with_penalty(f, g, h, r, gq, ukind, urow, ucol, w, kx, d, status, msg)
    if (status == MLID_OK) call operator_mu(d, t, ncell, mu, u, status, msg)
    if (status /= MLID_OK .and. mu <= 0.0_wp .and. any(kx /= 0.0_wp) .and. &
        index(msg, 'do not affect') > 0) then
      msg = 'the state penalty outweighs the information of every input: lower its weight'
    end if
  end subroutine mlid_design_mu

  !> The critical length T of mu (method 1 Riccati, 2 transition matrix),
  !> searched up to tmax; lam0(na), na = (m+1) nx: the costate lambda(0)
  !> (transition method only); kx the state penalty as in mlid_design_mu.
  subroutine mlid_design_length(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w, kx, mu, tmax, &
                                method, na, t, lam0, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, method, na
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), w(m), &
                                  kx(nx, nx), mu, tmax
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: t, lam0(na)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    t = 0.0_wp
    lam0 = 0.0_wp
    call design_with_penalty(f, g, h, r, gq, ukind, urow, ucol, w, kx, d, status, msg)
    if (status /= MLID_OK) return
    if (na /= d%na) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0)') 'lam0 needs (m+1) nx = ', d%na
      return
    end if
    if (method == 1) then
      call riccati_length(d, mu, tmax, t, status, msg)
    else if (method == 2) then
      call transition_length(d, mu, tmax, t, lam0, status, msg)
    else
      status = MLID_ERR_INPUT
      msg = 'method must be 1 (Riccati) or 2 (transition matrix)'
    end if
  end subroutine mlid_design_length

  !> The optimal input from the costate lam0 (transition method) on ncell
  !> cells of [0, T], unit energy.
  subroutine mlid_design_input(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w, mu, t, na, &
                               lam0, ncell, u, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, na, ncell
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), w(m), mu, t
    real(c_double), intent(in) :: lam0(na)
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: u(ncell*nu)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    u = 0.0_wp
    call design_create(f, g, h, r, ukind, urow, ucol, w, d, status, msg, gq)
    if (status /= MLID_OK) return
    if (na /= d%na) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0)') 'lam0 needs (m+1) nx = ', d%na
      return
    end if
    call costate_input(d, mu, t, lam0, ncell, u, status, msg)
  end subroutine mlid_design_input

  !> The information matrix mm(m, m) (unweighted, eq. 7.12) of the input u
  !> held over ncell cells of [0, T] (nu per cell).
  subroutine mlid_design_information(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, t, ncell, u, &
                                     mm, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, ncell
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), t, u(ncell*nu)
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: mm(m, m)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    real(wp) :: ones(m)
    mm = 0.0_wp
    ones = 1.0_wp
    if (.not. all(ieee_is_finite(u))) then
      status = MLID_ERR_INPUT
      msg = 'input is not finite'
      return
    end if
    call design_create(f, g, h, r, ukind, urow, ucol, ones, d, status, msg, gq)
    if (status == MLID_OK) call input_information(d, t, ncell, u, mm, status, msg)
  end subroutine mlid_design_information

  !> The best square wave |u| = peak held over ncell cells of [0, T]
  !> (mlid_design amplitude_limited_input); trwm its weighted trace.
  subroutine mlid_design_amplitude(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w, t, &
                                   ncell, peak, u, trwm, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, ncell
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), &
                                  w(m), t, peak
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: u(ncell*nu), trwm
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    u = 0.0_wp
    trwm = 0.0_wp
    call design_create(f, g, h, r, ukind, urow, ucol, w, d, status, msg, gq)
    if (status == MLID_OK) call amplitude_limited_input(d, t, ncell, peak, u, trwm, status, msg)
  end subroutine mlid_design_amplitude

  !> mu_max for the length td by the secant iteration of eq. 7.89 on the
  !> Riccati critical length, started within RICCATI_BRACKET of mu0 (the operator's).
  subroutine mlid_design_mu_for_length(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w, td, &
                                       mu0, mu, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), w(m), td, mu0
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: mu
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    mu = 0.0_wp
    call design_create(f, g, h, r, ukind, urow, ucol, w, d, status, msg, gq)
    if (status == MLID_OK) call mu_for_length(d, td, (1.0_wp - RICCATI_BRACKET)*mu0, &
                                              (1.0_wp + RICCATI_BRACKET)*mu0, mu, status, msg)
  end subroutine mlid_design_mu_for_length

  !> The states x(nx, 0:ncell ns) of x' = F x + G u, x(0) = 0, under the input
  !> u held over ncell cells of [0, T], at ns substeps per cell.
  subroutine mlid_design_response(nx, nu, f, g, t, ncell, ns, u, x, status, msg)
    integer(c_int), intent(in) :: nx, nu, ncell, ns
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), t, u(ncell*nu)
    real(c_double), intent(out) :: x(nx, ncell*ns + 1)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    x = 0.0_wp
    if (.not. (all(ieee_is_finite(u)) .and. all(ieee_is_finite(f)) .and. &
               all(ieee_is_finite(g)))) then
      status = MLID_ERR_INPUT
      msg = 'F, G and the input must be finite'
      return
    end if
    call input_response(f, g, t, ncell, ns, u, x, status, msg)
  end subroutine mlid_design_response

  !> The weighted-trace design of report 7.8 (mlid_design equalised_input): from
  !> weights w0, at most iterations updates of eq. 7.88 from step alpha; w
  !> the weights kept, u the input on 2 ncell cells (energy e, nu per
  !> cell), mu, mm its unweighted information, ratios(1:nratio) the
  !> diag(WM) max/min of each design kept.
  subroutine mlid_design_equalised(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w0, t, &
                                   ncell, e, iterations, alpha, w, u, mu, mm, ratios, nratio, &
                                   status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, ncell, iterations
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), &
                                  w0(m), t, e, alpha
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: w(m), u(2*ncell*nu), mu, mm(m, m), ratios(iterations + 1)
    integer(c_int), intent(out) :: nratio, status
    character(len=256), intent(out) :: msg
    call equalised_input(f, g, h, r, gq, ukind, urow, ucol, w0, t, ncell, e, iterations, alpha, &
                         w, u, mu, mm, ratios, nratio, status, msg)
  end subroutine mlid_design_equalised

  !> Run job k of handle h's deck when it runs whole in the core
  !> (simulate, design, monte_carlo: mlid_jobs), as mlid-batch runs it:
  !> its files written, its report and JSON object returned (empty when it
  !> failed: status, msg).
  subroutine mlid_deck_case_run(h, k, report, nreport, json, njson, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    character(len=262144), intent(out) :: report, json
    integer(c_int), intent(out) :: nreport, njson, status
    character(len=256), intent(out) :: msg
    character(len=:), allocatable :: rtext, jtext
    type(case_t), pointer :: c
    report = ''
    json = ''
    nreport = 0
    njson = 0
    c => case_at(h, k)
    call no_case(c, status, msg)
    if (status /= MLID_OK) return
    call job_run(c, rtext, jtext, status, msg)
    nreport = min(len(rtext), len(report))
    report = rtext
    njson = min(len(jtext), len(json))
    json = jtext
  end subroutine mlid_deck_case_run

  !> The number of frequencies of a measured response from segments of lseg
  !> samples (those of the transform's length fft_length(lseg), but 0 Hz).
  subroutine mlid_freq_count(lseg, nfreq)
    integer(c_int), intent(in) :: lseg
    integer(c_int), intent(out) :: nfreq
    nfreq = fft_length(max(lseg, 2))/2
  end subroutine mlid_freq_count

  !> The frequency response y/u of a record (mlid_freq_response): segments
  !> of lseg samples overlapping by nover within each of its nseg manoeuvres
  !> (starting at samples segstart); f (Hz), H, coherence, spectra, gain
  !> (dB), phase (deg, unwrapped), their random errors (1 sigma) and the
  !> number of averages nd.  nfreq from mlid_freq_count.
  subroutine mlid_freq_response(nt, u, y, dt, nseg, segstart, lseg, nover, nfreq, f, h_re, h_im, &
                                coh, guu, gyy, gain, phase, sgain, sphase, nd, status, msg)
    integer(c_int), intent(in) :: nt, lseg, nover, nfreq, nseg, segstart(nseg)
    real(c_double), intent(in) :: u(nt), y(nt), dt
    real(c_double), intent(out), dimension(nfreq) :: f, h_re, h_im, coh, guu, gyy, gain, phase, &
                                                     sgain, sphase
    integer(c_int), intent(out) :: nd, status
    character(len=256), intent(out) :: msg
    real(wp), allocatable :: ff(:), uu(:), yy(:)
    complex(wp), allocatable :: uy(:)
    complex(wp) :: h(nfreq)
    integer :: ndi, st
    f = 0.0_wp
    h_re = 0.0_wp
    h_im = 0.0_wp
    coh = 0.0_wp
    guu = 0.0_wp
    gyy = 0.0_wp
    gain = 0.0_wp
    phase = 0.0_wp
    sgain = 0.0_wp
    sphase = 0.0_wp
    nd = 0
    if (.not. (all(ieee_is_finite(u)) .and. all(ieee_is_finite(y)))) then
      status = MLID_ERR_INPUT
      msg = 'frequency response: the input or output channel has a value that is not finite'
      return
    end if
    call welch_spectra(u, y, dt, lseg, nover, segstart, ff, uu, yy, uy, ndi, st, msg)
    status = st
    if (st /= MLID_OK) return
    if (size(ff) /= nfreq) then
      status = MLID_ERR_INPUT
      msg = 'frequency response: nfreq is not mlid_freq_count(lseg)'
      return
    end if
    call response_from_spectra(uu, yy, uy, ndi, h, coh, gain, phase, sgain, sphase)
    f = ff
    guu = uu
    gyy = yy
    h_re = real(h)
    h_im = aimag(h)
    nd = ndi
  end subroutine mlid_freq_response

  !> The frequency response T (ny, nu, nfreq) of a linear model at w (rad/s)
  !> with its derivatives dT/dq (ny, nu, nfreq, nq) through jac = dtheta/dq,
  !> and gain (dB), phase (deg, unwrapped) and their sigmas from cov(q) by
  !> the delta method (mlid_freq_response).
  subroutine mlid_model_freq_response(mkind, nx, nu, ny, nw, nth, theta, nic, iconst, nrc, rconst, &
                                      nq, jac, cov, nfreq, w, t_re, t_im, dt_re, dt_im, gain, &
                                      phase, sgain, sphase, status, msg)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nth, nic, nrc, nq, nfreq
    real(c_double), intent(in) :: theta(nth), rconst(nrc), jac(nth, nq), cov(nq, nq), w(nfreq)
    integer(c_int), intent(in) :: iconst(nic)
    real(c_double), intent(out), dimension(ny, nu, nfreq) :: t_re, t_im, gain, phase, sgain, sphase
    real(c_double), intent(out), dimension(ny, nu, nfreq, nq) :: dt_re, dt_im
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    class(model_t), allocatable :: m
    complex(wp) :: t(ny, nu, nfreq), dt(ny, nu, nfreq, nq)
    t_re = 0.0_wp
    t_im = 0.0_wp
    dt_re = 0.0_wp
    dt_im = 0.0_wp
    gain = 0.0_wp
    phase = 0.0_wp
    sgain = 0.0_wp
    sphase = 0.0_wp
    call model_create(mkind, nx, nu, ny, nw, iconst, rconst, m, status, msg)
    if (status /= MLID_OK) return
    call model_response(m, theta, w, jac, t, dt, status, msg)
    if (status /= MLID_OK) return
    call response_bands(t, dt, cov, gain, phase, sgain, sphase)
    t_re = real(t)
    t_im = aimag(t)
    dt_re = real(dt)
    dt_im = aimag(dt)
  end subroutine mlid_model_freq_response

  !> Weights of the transfer-function mismatch: 1, or by coherence.
  pure function tf_weights(coh, use_coh) result(wt)
    real(c_double), intent(in) :: coh(:)
    integer(c_int), intent(in) :: use_coh
    real(wp) :: wt(size(coh))
    wt = 1.0_wp
    if (use_coh /= 0) wt = coherence_weight(coh)
  end function tf_weights

  !> Fit T(s) = N(s)/D(s) e^(-tau s) (orders m, n; delay when delay = 1)
  !> to gain (dB) and phase (deg) at w (rad/s) by the handling-qualities
  !> mismatch (mlid_transfer_fit), weighted by coherence when use_coh = 1;
  !> from x0 when use_start = 1, else from Levy's least squares with the
  !> delay at tau0.  x: [b_0..b_m, a_0..a_(n-1), tau]; xs the start used.
  !> Parameters with isfree = 0 keep their value in x0.
  subroutine mlid_tf_fit(nfreq, w, gain, phase, coh, use_coh, m, n, delay, tau0, use_start, &
                         np, x0, isfree, max_iter, xs, x, cov, cost, niter, status, msg)
    integer(c_int), intent(in) :: nfreq, use_coh, m, n, delay, use_start, np, max_iter
    integer(c_int), intent(in) :: isfree(np)
    real(c_double), intent(in) :: w(nfreq), gain(nfreq), phase(nfreq), coh(nfreq), tau0, x0(np)
    real(c_double), intent(out) :: xs(np), x(np), cov(np, np), cost
    integer(c_int), intent(out) :: niter, status
    character(len=256), intent(out) :: msg
    real(wp) :: xw(np), cw(np, np), cst
    integer :: it
    xs = 0.0_wp
    x = 0.0_wp
    cov = 0.0_wp
    cost = 0.0_wp
    niter = 0
    call tf_check(nfreq, w, gain, phase, m, n, delay, np, status, msg)
    if (status /= MLID_OK) return
    if (use_start /= 0) then
      xw = x0
    else
      xw = x0                                           ! the fixed ones' values
      call tf_start(m, n, delay /= 0, tau0, w, gain, phase, tf_weights(coh, use_coh), isfree /= 0, &
                    xw, status, msg)
      if (status /= MLID_OK) return
    end if
    xs = xw
    call tf_fit(m, n, delay /= 0, w, gain, phase, tf_weights(coh, use_coh), isfree /= 0, max_iter, &
                xw, cst, cw, it, status, msg)
    x = xw
    cov = cw
    cost = cst
    niter = it
  end subroutine mlid_tf_fit

  !> Orders, sizes and frequencies of a transfer-function fit.
  subroutine tf_check(nfreq, w, gain, phase, m, n, delay, np, status, msg)
    integer(c_int), intent(in) :: nfreq, m, n, delay, np
    real(c_double), intent(in) :: w(:), gain(:), phase(:)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call tf_orders(m, n, delay, np, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (2*nfreq < np + 1) then
      write (msg, '(a,i0,a,i0,a)') 'transfer-function fit: ', nfreq, &
        ' frequencies are too few for ', np, ' parameters'
    else if (.not. (all(ieee_is_finite(w)) .and. all(ieee_is_finite(gain)) .and. &
                    all(ieee_is_finite(phase)))) then
      msg = 'transfer-function fit: a frequency, gain or phase is not finite'
    else if (any(w <= 0.0_wp)) then
      msg = 'transfer-function fit: frequencies must be positive'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine tf_check

  !> The mismatch's residuals r (2 nfreq, r'r = cost) and their Jacobian.
  subroutine mlid_tf_residuals(nfreq, w, gain, phase, coh, use_coh, m, n, delay, np, x, r, jr, &
                               status, msg)
    integer(c_int), intent(in) :: nfreq, use_coh, m, n, delay, np
    real(c_double), intent(in) :: w(nfreq), gain(nfreq), phase(nfreq), coh(nfreq), x(np)
    real(c_double), intent(out) :: r(2*nfreq), jr(2*nfreq, np)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    r = 0.0_wp
    jr = 0.0_wp
    call tf_orders(m, n, delay, np, status, msg)
    if (status /= MLID_OK) return
    call tf_residuals(m, n, delay /= 0, x, w, gain, phase, tf_weights(coh, use_coh), r, jr)
  end subroutine mlid_tf_residuals

  !> Orders m >= 0, n >= 1 and np = tf_size, the length of x: the
  !> parameters b_0..b_m, a_0..a_(n-1) and tau when delay = 1.
  subroutine tf_orders(m, n, delay, np, status, msg)
    integer(c_int), intent(in) :: m, n, delay, np
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    status = MLID_OK
    msg = ''
    if (m < 0 .or. n < 1) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0,a)') 'transfer function: orders m = ', m, ', n = ', n, &
        ' must be m >= 0, n >= 1'
    else if (np /= tf_size(m, n, delay /= 0)) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0,a,i0,a,i0,a,i0)') 'transfer function: orders m = ', m, ', n = ', &
        n, ' (delay ', delay, ') take ', tf_size(m, n, delay /= 0), ' parameters, got ', np
    end if
  end subroutine tf_orders

  !> Gain (dB) and phase (deg, unwrapped) of a fitted transfer function at w.
  subroutine mlid_tf_response(nfreq, w, m, n, delay, np, x, gain, phase, status, msg)
    integer(c_int), intent(in) :: nfreq, m, n, delay, np
    real(c_double), intent(in) :: w(nfreq), x(np)
    real(c_double), intent(out) :: gain(nfreq), phase(nfreq)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    complex(wp) :: lt, dlt(np)
    integer :: k
    gain = 0.0_wp
    phase = 0.0_wp
    call tf_orders(m, n, delay, np, status, msg)
    if (status /= MLID_OK) return
    do k = 1, nfreq
      call tf_log_response(m, n, delay /= 0, x, w(k), lt, dlt)
      gain(k) = DB*real(lt)
      phase(k) = DEG*aimag(lt)
    end do
    call unwrap_deg(phase)
  end subroutine mlid_tf_response

  !> The design problem, with the state-limit penalty kx(nx,nx) of report
  !> 7.6 when kx is not zero (a zero kx is no penalty: the plain design).
  subroutine design_with_penalty(f, g, h, r, gq, ukind, urow, ucol, w, kx, d, status, msg)
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), r(:, :), gq(:, :), w(:), kx(:, :)
    integer(c_int), intent(in) :: ukind(:), urow(:), ucol(:)
    type(design_t), intent(out) :: d
    integer(c_int), intent(out) :: status
    character(len=*), intent(out) :: msg
    call design_create(f, g, h, r, ukind, urow, ucol, w, d, status, msg, gq)
    if (status == MLID_OK .and. any(kx /= 0.0_wp)) call design_state_penalty(d, kx, status, msg)
  end subroutine design_with_penalty

  !> The ties of the flat interface: the first ntie terms (no more than given).
  pure function ties_of(ntie, tie_to, tie_from, tie_scale, tie_offset) result(tie)
    integer(c_int), intent(in) :: ntie, tie_to(:), tie_from(:)
    real(c_double), intent(in) :: tie_scale(:), tie_offset(:)
    type(tie_t) :: tie
    integer :: n
    n = max(0, min(ntie, size(tie_to), size(tie_from), size(tie_scale)))
    tie = tie_t(tie_to(1:n), tie_from(1:n), tie_scale(1:n), tie_offset)
  end function ties_of


end module mlid_api
