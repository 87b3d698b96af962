!> The flat interface's models and options: the option table by name,
!> layouts and element names, ties, the six-degree-of-freedom and
!> flight-path models' text, parameter units, Jacobian checks, input
!> signals, and the core's name lists.
!> Conventions: mlid_api_deck's comment.
module mlid_api_models
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan, ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, stop_reason_text, fit_outcome
  use mlid_models, only: model_t
  use mlid_model_factory, only: model_create, MODEL_KIND_NAMES
  use mlid_options, only: options_t, options_from_flat, options_to_flat, NOPTION, OPTION_NAMES, &
                          option_kind, option_set, option_get
  use mlid_ties, only: tie_parse, MAXTERM
  use mlid_inputs, only: input_signal
  use mlid_case, only: NAMELEN
  use mlid_text, only: join_lines, split_lines, name_lines, joined
  use mlid_sixdof, only: sixdof_parts, SIXDOF_CONSTANTS
  use mlid_flightpath, only: flightpath_text, flightpath_corrected, FLIGHTPATH_CONSTANTS, &
                             FLIGHTPATH_CORRECTIONS, FLIGHTPATH_OUTPUTS, FLIGHTPATH_INPUTS
  use mlid_record, only: record_text
  use mlid_units, only: UNITLEN
  use mlid_aero_long, only: REGRESSOR_NAMES, CONSTANT_NAMES
  use mlid_param_units, only: param_units
  use mlid_layout, only: layout_table_t, layout_of, element_name, default_label, manoeuvre_map
  use mlid_jacobian_check, only: check_jacobians
  use mlid_named, only: VALUE_KIND_NAMES
  use mlid_run, only: corrected_record
  implicit none
  private
  public :: mlid_input_signal, mlid_default_options, mlid_option_info, mlid_option_set, &
            mlid_option_get, mlid_options_check, mlid_stop_reason, mlid_fit_outcome, &
            mlid_tie_parse, mlid_sixdof_constants, mlid_sixdof_text, mlid_flightpath_lists, &
            mlid_flightpath_model_text, mlid_flightpath_corrected, mlid_layout_size, &
            mlid_layout, mlid_manoeuvre_map, mlid_parameter_units, mlid_name_list, mlid_limit, &
            mlid_model_sizes, mlid_check_jacobians

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

  !> A tie written as text (mlid_ties) for a model: the tied entry, its
  !> constant and its terms (n of them, at most MAXTERM: 16 below, a literal
  !> for f2py, which reads no module parameter).
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
  !> 'value_kinds' and 'model_kinds' (by code).
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

end module mlid_api_models
