!> The flat interface's handles, decks and records: a handle (mlid_handles)
!> per deck or record read, its cases' parts, the channels a case or a
!> file gives, and running a case's core job.
!>
!> Conventions of every mlid_api_* module (f2py wraps them all as
!> mlid._core; python/mlid/_bridge.py joins them into one interface):
!> explicit-shape arrays of C kinds, a status code and a message out.
!>   mkind, nx, nu, ny, nw   model kind (mlid_model_factory), sizes, noise inputs
!>   theta(nth)              all parameters [p, x0, bias, q, r, s] (mlid_models)
!>   isfree(nth)             1 where the parameter is estimated, else 0
!>   ntie, mtie, tie_to, tie_from, tie_scale (mtie >= max(ntie, 1)), tie_offset(nth)
!>                           affine ties: theta(to) := offset(to) + sum scale*theta(from)
!>   iconst, rconst          model constants (unused by the linear model)
!>   t(nt), u(nu,nt), y(ny,nt)   the record, one column per sample
!>   iopt(16), ropt(16)      options, layout in mlid_options
!>   status, msg             0 and '' on success, see mlid_kinds
module mlid_api_deck
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan, ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_monte_carlo, only: monte_carlo
  use mlid_deck, only: deck_read, corrected_writable
  use mlid_handles, only: session_t, handle_new, handle_session, handle_free
  use mlid_case, only: case_t, NAMELEN, NCONDITION, CONDITION_NAMES
  use mlid_text, only: join_lines, split_lines, joined
  use mlid_sampling, only: record_check_segments
  use mlid_channels, only: channels_t, channel_set_t, channels_spec, channels_read, channels_table
  use mlid_units, only: UNITLEN
  use mlid_run, only: run_case
  use mlid_named, only: named_t, VALUE_TEXT
  implicit none
  private
  public :: mlid_handle_new, mlid_handle_free, mlid_deck_open, mlid_deck_case, &
            mlid_condition_names, mlid_deck_case_condition, mlid_deck_case_model, &
            mlid_deck_case_data, mlid_deck_case_ties, mlid_deck_case_corrected_writable, &
            mlid_deck_case_corrected, mlid_deck_case_holdout, mlid_deck_case_initial_states, &
            mlid_deck_case_record, mlid_channels_read, &
            mlid_channels_table, mlid_channels_get, mlid_deck_case_run, mlid_case_result_info, &
            mlid_case_result, mlid_case_result_text, mlid_check_time

contains

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

  !> Read a record's channels (mlid_channels: text, or a .mat or HDF5 file,
  !> variable naming its matrix when it holds several, '' for none) and keep
  !> them in handle h for mlid_channels_get.  The spec as channels_spec takes
  !> it: one entry per line; t_start, t_end: the window.  Status OK with msg 'warning: ...'
  !> when a channel looks wrong for its declared unit (degrees in rad).
  subroutine mlid_channels_read(h, path, variable, time, inputs, outputs, columns, units, derived, &
                                show, skip_rows, t_start, t_end, dt, nt, status, msg)
    integer(c_int64_t), intent(in) :: h
    character(len=*), intent(in) :: path, variable, time, inputs, outputs, columns, units, &
                                    derived, show
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
    spec%variable = variable
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

  !> Run case k of handle h's deck, whatever its job (mlid_run's run_case,
  !> as mlid-batch runs it, on a copy of the case: it can run again): its
  !> files written, its report lines, JSON object and notes (one a line)
  !> returned, each ending where its length says; a fit's numbers are kept
  !> in h for mlid_case_result.  status, msg: the case's.
  subroutine mlid_deck_case_run(h, k, report, nreport, json, njson, notes, nnotes, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    character(len=262144), intent(out) :: report, json
    character(len=65536), intent(out) :: notes
    integer(c_int), intent(out) :: nreport, njson, nnotes, status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(case_t), pointer :: c
    type(case_t) :: work
    character(len=:), allocatable :: text
    integer :: j
    report = ''
    json = ''
    notes = ''
    nreport = 0
    njson = 0
    nnotes = 0
    c => case_at(h, k)
    call no_case(c, status, msg)
    if (status /= MLID_OK) return
    call handle_session(h, s, status, msg)
    if (.not. allocated(s%runs)) allocate (s%runs(size(s%cases)))
    work = c
    call run_case(work, s%runs(k))
    associate (r => s%runs(k))
      status = r%status
      msg = r%msg
      nreport = min(len(r%report), len(report))
      report = r%report
      njson = min(len(r%json), len(json))
      json = r%json
      text = ''
      do j = 1, size(r%notes)
        text = text//r%notes(j)%s//achar(10)
      end do
      nnotes = min(len(text), len(notes))
      notes = text
    end associate
  end subroutine mlid_deck_case_run

  !> What the last run of case k of handle h kept under name (a fit's
  !> numbers: mlid_run's put_fit; a validation's statistics): its kind
  !> (0 none, mlid_named's VALUE_REAL, VALUE_INT, VALUE_TEXT), rank and
  !> shape (a text's length).
  subroutine mlid_case_result_info(h, k, name, kind, rank, shp)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    character(len=*), intent(in) :: name
    integer(c_int), intent(out) :: kind, rank, shp(3)
    type(named_t), pointer :: results
    integer :: j
    kind = 0
    rank = 0
    shp = 0
    results => run_results(h, k)
    if (.not. associated(results)) return
    j = results%find(name)
    if (j == 0) return
    kind = results%v(j)%kind
    rank = results%v(j)%rank
    shp = results%v(j)%shape
    if (kind == VALUE_TEXT) shp(1) = len(results%v(j)%t)
  end subroutine mlid_case_result_info

  !> The n numbers (Fortran order) kept under name by case k's last run.
  subroutine mlid_case_result(h, k, name, n, values, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, n
    character(len=*), intent(in) :: name
    real(c_double), intent(out) :: values(n)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(named_t), pointer :: results
    integer :: j
    values = 0.0_wp
    status = MLID_ERR_INPUT
    msg = 'case has no result '''//trim(name)//''''
    results => run_results(h, k)
    if (.not. associated(results)) return
    j = results%find(name)
    if (j == 0) return
    associate (v => results%v(j))
      if (allocated(v%r)) then
        if (size(v%r) /= n) return
        values = v%r
      else if (allocated(v%i)) then
        if (size(v%i) /= n) return
        values = real(v%i, wp)
      else
        return
      end if
    end associate
    status = MLID_OK
    msg = ''
  end subroutine mlid_case_result

  !> The text kept under name by case k's last run (a fit's message).
  subroutine mlid_case_result_text(h, k, name, text)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    character(len=*), intent(in) :: name
    character(len=256), intent(out) :: text
    type(named_t), pointer :: results
    integer :: j
    text = ''
    results => run_results(h, k)
    if (.not. associated(results)) return
    j = results%find(name)
    if (j == 0) return
    if (allocated(results%v(j)%t)) text = results%v(j)%t
  end subroutine mlid_case_result_text

  !> The results of case k's last run in handle h; null when it has none.
  function run_results(h, k) result(results)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    type(named_t), pointer :: results
    type(session_t), pointer :: s
    integer :: status
    character(len=64) :: msg
    results => null()
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    if (.not. allocated(s%runs)) return
    if (k < 1 .or. k > size(s%runs)) return
    results => s%runs(k)%results
  end function run_results

  !> Time increasing and without gaps (a step over 1.5 times the median),
  !> each manoeuvre of a joined record on its own (segstart: first samples).
  subroutine mlid_check_time(nt, t, nseg, segstart, status, msg)
    integer(c_int), intent(in) :: nt, nseg, segstart(nseg)
    real(c_double), intent(in) :: t(nt)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call record_check_segments(t, segstart, status, msg)
  end subroutine mlid_check_time

end module mlid_api_deck
