!> Flight-data channels: which channels of a record a case takes (time,
!> inputs, outputs, each by column number or by name), the units they are
!> recorded in (converted to the core's: SI, angles in rad), channels
!> derived from others by a small expression language (mlid_expr), the
!> units channels are shown in (display only), and the time window taken of
!> each file.  A channel declared in rad that goes beyond 2 pi warns.  One
!> path for every source: a text record read by mlid_record (both front
!> ends), the table of a .mat or HDF5 file read by mlid_tablefile, or a
!> table the Python front end gives (a DataFrame's).
!>
!> Names: a column is named by the deck's `columns` (in order), else by the
!> file's header; 'ALCG[deg]' names ALCG with its unit.  A name is matched
!> exactly, else case-insensitively when that is unique.  Derived channels
!> are computed from converted values, in order, each from the columns and
!> the derived channels before it; a derived channel has the unit its
!> channels share (none when they differ).
!>
!> Joined files (join): text files whose columns extend the data files'
!> rows, row for row.  Read one after another, the join files' rows match
!> the case's data files' rows read one after another (one join file per
!> data file, or one for all of them, or any split): the totals must agree.
!> Their columns come after the data file's, named by join_columns or
!> their header, and are used like any other column.
module mlid_channels
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, msg_len, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: itoa, to_lower, line_t, joined, text_lines, short_path, seconds, &
                       number_text
  use mlid_record, only: record_t, record_read, NAMELEN
  use mlid_sampling, only: record_check_time
  use mlid_expr, only: expr_t, expr_compile, expr_eval, expr_uses, split_definition
  use mlid_units, only: unit_to_core, units_of, UNITLEN
  use mlid_tablefile, only: tablefile_read
  use mlid_progress, only: progress_t
  use mlid_smooth, only: smooth_fourier, smooth_uniform_check
  use mlid_local_smooth, only: smooth_local, deriv_local, LOCAL_NO_CUTOFF
  implicit none
  private
  public :: channels_t, channel_set_t, channels_spec, channels_join, channels_read, &
            channels_table, NAMELEN

  !> What a case takes of its records.
  type :: channels_t
    character(len=NAMELEN) :: time = '1'
    character(len=NAMELEN), allocatable :: inputs(:), outputs(:)
    character(len=NAMELEN + UNITLEN + 2), allocatable :: columns(:)  !< names the file's columns
    type(line_t), allocatable :: units(:)      !< 'NAME = unit'
    type(line_t), allocatable :: derived(:)    !< 'NAME = expression'
    type(line_t), allocatable :: show(:)       !< 'NAME = unit' it is shown in
    integer :: skip_rows = 0
    character(len=NAMELEN) :: variable = ''   !< the matrix of a .mat or HDF5 file holding several
    !> > 0: the time rebuilt at this step from the window's first sample,
    !> the recorded time used only to cut the window (a recording gap is then
    !> integrated across, as the textbook software does); 0: the record's time.
    real(wp) :: dt = 0.0_wp
    integer :: manoeuvre = 0    !< > 0: the file's place in its case's list (with_manoeuvre)
    type(line_t), allocatable :: join(:)       !< files whose columns extend the rows
    character(len=NAMELEN + UNITLEN + 2), allocatable :: join_columns(:)  !< names them
    type(line_t), allocatable :: files(:)      !< the case's data files in order (join's rows)
  end type channels_t

  !> One manoeuvre's channels as taken, in the core's units: t(nt),
  !> u(nu, nt), y(ny, nt); names, core units, the units declared (for
  !> display: declared value = (core value - offset)/scale), and the line
  !> (text) or row (table) each sample came from.
  type :: channel_set_t
    real(wp), allocatable :: t(:), u(:, :), y(:, :)
    character(len=NAMELEN), allocatable :: names(:)        !< inputs, then outputs
    character(len=UNITLEN), allocatable :: units(:), shown(:)
    real(wp), allocatable :: scale(:), offset(:)
    integer, allocatable :: line(:)
  end type channel_set_t

  !> The channels of one source: its columns, then the derived ones.  Each
  !> has the unit its record declares, converted to the core's unit by
  !> core = factor*declared + offset, and the unit it is shown in
  !> (the declared one unless `show` names another): core = dscale*shown + doffset.
  type :: plan_t
    integer :: ncol = 0
    character(len=NAMELEN), allocatable :: name(:)
    character(len=UNITLEN), allocatable :: unit(:), declared(:), shown(:)
    real(wp), allocatable :: factor(:), offset(:), dscale(:), doffset(:)
    logical, allocatable :: need(:)
    type(expr_t), allocatable :: expr(:)
    !> per derived channel: 0 an expression, else its place in SMOOTHERS (of src)
    integer, allocatable :: op(:), src(:)
    real(wp), allocatable :: fc(:)           !< smooth/deriv's cut-off [Hz], 0: the rule's
    integer :: itime = 0, nin = 0
    integer, allocatable :: pick(:)          !< inputs, then outputs
  end type plan_t

  !> The smoothing functions of a derived channel, each of one channel:
  !> global Fourier (mlid_smooth) and local (mlid_local_smooth); the even
  !> places are derivatives.
  character(len=*), parameter :: SMOOTHERS(4) = [character(len=12) :: 'smooth', 'deriv', &
                                                 'smooth_local', 'deriv_local']
  character(len=*), parameter :: SMOOTHERS_USE = 'smooth(p), deriv(p), deriv(p, 2.5) (a '// &
                                                 'cut-off in Hz), smooth_local(p) or deriv_local(p)'

contains

  !> The spec from texts, one entry per line (the flat interface's form):
  !> time, inputs, outputs and columns name or number channels; units and
  !> show are 'NAME = unit', derived 'NAME = expression'.
  subroutine channels_spec(time, inputs, outputs, columns, units, derived, show, skip_rows, &
                           spec, status, msg)
    character(len=*), intent(in) :: time, inputs, outputs, columns, units, derived, show
    integer, intent(in) :: skip_rows
    type(channels_t), intent(out) :: spec
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(line_t), allocatable :: all(:)
    integer :: k

    all = [text_lines(time), text_lines(inputs), text_lines(outputs)]
    status = MLID_ERR_INPUT
    do k = 1, size(all)
      if (len(all(k)%s) > NAMELEN) then
        msg = 'channel '''//all(k)%s//''' is longer than '//itoa(NAMELEN)//' characters'
        return
      end if
    end do
    all = text_lines(columns)
    do k = 1, size(all)
      if (len(all(k)%s) > len(spec%columns)) then
        msg = 'column '''//all(k)%s//''' is longer than '//itoa(len(spec%columns))// &
              ' characters'
        return
      end if
    end do
    if (size(text_lines(time)) /= 1) then
      msg = 'one time channel is needed, '//itoa(size(text_lines(time)))//' given'
      return
    end if
    all = text_lines(time)
    spec%time = all(1)%s
    spec%inputs = names_of_lines(text_lines(inputs))
    spec%outputs = names_of_lines(text_lines(outputs))
    spec%columns = names_of_lines(text_lines(columns))
    spec%units = text_lines(units)
    spec%derived = text_lines(derived)
    spec%show = text_lines(show)
    spec%skip_rows = skip_rows
    status = MLID_OK
    msg = ''
    if (skip_rows < 0) then
      status = MLID_ERR_INPUT
      msg = 'skip_rows must be >= 0'
    end if
  end subroutine channels_spec

  function names_of_lines(lines) result(names)
    type(line_t), intent(in) :: lines(:)
    character(len=NAMELEN + UNITLEN + 2) :: names(size(lines))
    integer :: k
    do k = 1, size(lines)
      names(k) = lines(k)%s
    end do
  end function names_of_lines

  !> A record's channels: a text record's through the one record reader
  !> (the header is read first: names, units, number of columns; then only
  !> the columns the case needs are converted), a .mat or HDF5 file's
  !> through its table (mlid_tablefile), taken as channels_table takes one.
  !> progress: how far the text record's rows are read (mlid_progress).
  subroutine channels_read(path, spec_in, t_start, t_end, set, status, msg, manoeuvre, progress)
    character(len=*), intent(in) :: path
    type(channels_t), intent(in) :: spec_in
    real(wp), intent(in) :: t_start, t_end
    type(channel_set_t), intent(out) :: set
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, intent(in), optional :: manoeuvre   !< the file's place in the case's list
    type(progress_t), intent(inout), optional :: progress
    type(channels_t) :: spec
    type(record_t) :: rec
    type(plan_t) :: plan
    real(wp), allocatable :: ch(:, :), jx(:, :), x(:, :)
    character(len=NAMELEN), allocatable :: names(:)
    character(len=UNITLEN), allocatable :: units(:)
    integer, allocatable :: cols(:)
    integer :: k, ndat

    spec = with_manoeuvre(spec_in, manoeuvre)
    if (binary_format(path)) then        ! a table, taken as a table the front end gives
      call tablefile_read(path, trim(spec%variable), x, names, units, status, msg)
      if (status /= MLID_OK) return
      call channels_table(path, x, names, units, spec_in, t_start, t_end, set, status, msg, &
                          manoeuvre)
      return
    end if
    call record_read(path, [integer ::], spec%skip_rows, rec, status, msg, header_only=.true.)
    if (status /= MLID_OK) return
    names = rec%names
    units = rec%units
    ndat = size(names)
    if (joining(spec)) then
      call join_header(spec, names, units, status, msg)
      if (status /= MLID_OK) return
    end if
    call make_plan(spec, names, units, plan, status, msg)
    if (status /= MLID_OK) then
      msg = 'data file '//short_path(path)//': '//trim(msg)
      return
    end if
    cols = pack([(k, k=1, ndat)], plan%need(1:ndat))
    call record_read(path, cols, spec%skip_rows, rec, status, msg, progress=progress)
    if (status /= MLID_OK) return
    allocate (ch(size(rec%x, 2), size(plan%name)))
    ch = 0.0_wp
    ch(:, cols) = transpose(rec%x)
    if (joining(spec)) then
      cols = pack([(k, k=1, plan%ncol - ndat)], plan%need(ndat + 1:plan%ncol))
      call join_rows(spec, path, size(ch, 1), cols, jx, status, msg)
      if (status /= MLID_OK) return
      ch(:, ndat + cols) = transpose(jx)
    end if
    call take(plan, ch, rec%line, 'data file '//short_path(path), 'line', t_start, t_end, &
              spec%dt, set, status, msg)
  end subroutine channels_read

  !> A table's channels: x(nrow, ncol) with its columns' names and units
  !> (either may be blank), read by the Python front end from a .mat or
  !> HDF5 file or a DataFrame; source names it in messages.
  subroutine channels_table(source, x, names, units, spec_in, t_start, t_end, set, status, msg, &
                            manoeuvre)
    character(len=*), intent(in) :: source
    real(wp), intent(in) :: x(:, :)
    character(len=*), intent(in) :: names(:), units(:)
    type(channels_t), intent(in) :: spec_in
    real(wp), intent(in) :: t_start, t_end
    type(channel_set_t), intent(out) :: set
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, intent(in), optional :: manoeuvre   !< the table's place in the case's list
    type(channels_t) :: spec
    type(plan_t) :: plan
    real(wp), allocatable :: ch(:, :)
    character(len=NAMELEN) :: nm(size(names))
    character(len=UNITLEN) :: un(size(units))
    integer :: k, r

    spec = with_manoeuvre(spec_in, manoeuvre)
    if (joining(spec)) then
      status = MLID_ERR_INPUT
      msg = 'data '//short_path(source)//': join extends text records; this one is a table'
      return
    end if
    nm = names
    un = units
    call make_plan(spec, nm, un, plan, status, msg)
    if (status /= MLID_OK) then
      msg = 'data '//short_path(source)//': '//trim(msg)
      return
    end if
    do k = 1, plan%ncol
      if (.not. plan%need(k)) cycle
      if (all(ieee_is_finite(x(:, k)))) cycle
      r = findloc(ieee_is_finite(x(:, k)), .false., 1)
      status = MLID_ERR_INPUT
      msg = 'data '//short_path(source)//' row '//itoa(r)//': column '//trim(label(plan, k))// &
            ' is not finite'
      return
    end do
    allocate (ch(size(x, 1), size(plan%name)))
    ch = 0.0_wp
    ch(:, 1:plan%ncol) = x
    call take(plan, ch, [(k, k=1, size(x, 1))], 'data '//short_path(source), 'row', t_start, &
              t_end, spec%dt, set, status, msg)
  end subroutine channels_table

  !> The join files, their columns' names (one per line, may be blank: the
  !> header's) and the case's data files in order, as the deck gives them.
  subroutine channels_join(spec, join, join_columns, files, status, msg)
    type(channels_t), intent(inout) :: spec
    type(line_t), intent(in) :: join(:), join_columns(:), files(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    status = MLID_ERR_INPUT
    if (size(join) == 0 .and. size(join_columns) > 0) then
      msg = 'join_columns names the columns of join files, and join lists none'
      return
    end if
    if (size(join) > 0 .and. size(files) == 0) then
      msg = 'join extends the data files, and there are none'
      return
    end if
    spec%join = join
    spec%join_columns = names_of_lines(join_columns)
    spec%files = files
    status = MLID_OK
    msg = ''
  end subroutine channels_join

  logical function joining(spec)
    type(channels_t), intent(in) :: spec
    joining = .false.
    if (allocated(spec%join)) joining = size(spec%join) > 0
  end function joining

  !> names and units extended by the join files' columns: named by
  !> join_columns, else by the first join file's header.
  subroutine join_header(spec, names, units, status, msg)
    type(channels_t), intent(in) :: spec
    character(len=NAMELEN), allocatable, intent(inout) :: names(:)
    character(len=UNITLEN), allocatable, intent(inout) :: units(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(record_t) :: rec
    integer :: k
    call record_read(spec%join(1)%s, [integer ::], 0, rec, status, msg, header_only=.true.)
    if (status /= MLID_OK) then
      msg = 'join '//trim(msg)
      return
    end if
    if (size(spec%join_columns) > rec%ncol) then
      status = MLID_ERR_INPUT
      msg = 'join file '//short_path(spec%join(1)%s)//': '//itoa(size(spec%join_columns))// &
            ' join_columns named, the file has '//itoa(rec%ncol)
      return
    end if
    do k = 1, size(spec%join_columns)
      call name_and_unit(spec%join_columns(k), rec%names(k), rec%units(k))
    end do
    names = [names, rec%names]
    units = [units, rec%units]
  end subroutine join_header

  !> Columns cols of the join files' rows that match data file path's n
  !> rows: the rows after those of the data files before it in the case's
  !> list.  The join files must have as many rows as all the data files.
  subroutine join_rows(spec, path, n, cols, x, status, msg)
    type(channels_t), intent(in) :: spec
    character(len=*), intent(in) :: path
    integer, intent(in) :: n, cols(:)
    real(wp), allocatable, intent(out) :: x(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(record_t) :: rec
    real(wp), allocatable :: all(:, :)
    integer :: k, before, total, ncol

    before = 0
    total = 0
    do k = 1, merge(size(spec%files), 0, spec%manoeuvre > 0)
      if (k == spec%manoeuvre) then
        total = total + n
        before = total - n
        cycle
      end if
      call record_read(spec%files(k)%s, [integer ::], spec%skip_rows, rec, status, msg)
      if (status /= MLID_OK) return
      total = total + size(rec%line)
    end do
    if (spec%manoeuvre == 0) total = n       ! a file on its own, not a case's
    allocate (all(size(cols), 0))
    do k = 1, size(spec%join)
      call record_read(spec%join(k)%s, cols, 0, rec, status, msg)
      if (status /= MLID_OK) then
        msg = 'join '//trim(msg)
        return
      end if
      if (k == 1) ncol = rec%ncol
      if (rec%ncol /= ncol) then
        status = MLID_ERR_INPUT
        msg = 'join file '//short_path(spec%join(k)%s)//': '//itoa(rec%ncol)// &
              ' columns, the first join file has '//itoa(ncol)
        return
      end if
      all = reshape([all, rec%x], [size(cols), size(all, 2) + size(rec%x, 2)])
    end do
    if (size(all, 2) /= total) then
      status = MLID_ERR_INPUT
      msg = 'data file '//short_path(path)//': the join files have '//itoa(size(all, 2))// &
            ' rows, the data files '//itoa(total)//' (matched row for row, one file '// &
            'after another)'
      return
    end if
    x = all(:, before + 1:before + n)
    status = MLID_OK
    msg = ''
  end subroutine join_rows

  !> A case's file k carries the channel 'manoeuvre' = k (a derived channel
  !> before the deck's own, so they may use it): per-manoeuvre parameters
  !> are then stated with indicator channels, step(manoeuvre - 1.5), ...
  function with_manoeuvre(spec_in, manoeuvre) result(spec)
    type(channels_t), intent(in) :: spec_in
    integer, intent(in), optional :: manoeuvre
    type(channels_t) :: spec
    spec = spec_in
    if (.not. present(manoeuvre)) return
    spec%manoeuvre = manoeuvre
    if (.not. allocated(spec%derived)) allocate (spec%derived(0))
    spec%derived = [line_t('manoeuvre = '//itoa(manoeuvre)), spec%derived]
  end function with_manoeuvre

  !> Names and units of the columns and derived channels, the derived
  !> channels compiled, the channels picked, and which columns are needed.
  subroutine make_plan(spec, names, units, plan, status, msg)
    type(channels_t), intent(in) :: spec
    character(len=NAMELEN), intent(in) :: names(:)
    character(len=UNITLEN), intent(in) :: units(:)
    type(plan_t), intent(out) :: plan
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, ncol, nder

    ncol = size(names)
    nder = 0
    if (allocated(spec%derived)) nder = size(spec%derived)
    plan%ncol = ncol
    allocate (plan%name(ncol + nder), plan%unit(ncol + nder), plan%declared(ncol + nder), &
              plan%factor(ncol + nder), plan%offset(ncol + nder), plan%need(ncol + nder), &
              plan%expr(nder), plan%op(nder), plan%src(nder), plan%fc(nder))
    plan%fc = 0.0_wp
    plan%op = 0
    plan%src = 0
    plan%name(1:ncol) = names
    plan%declared(1:ncol) = units
    plan%need = .false.
    status = MLID_ERR_INPUT
    if (allocated(spec%columns)) then
      if (size(spec%columns) > ncol) then
        msg = itoa(size(spec%columns))//' columns named, the file has '//itoa(ncol)
        return
      end if
      do k = 1, size(spec%columns)
        call name_and_unit(spec%columns(k), plan%name(k), plan%declared(k))
      end do
    end if
    if (spec%manoeuvre > 0 .and. any(to_lower(plan%name(1:ncol)) == 'manoeuvre')) then
      msg = 'column '//trim(plan%name(findloc(to_lower(plan%name(1:ncol)), 'manoeuvre', 1)))// &
            ': the name manoeuvre is reserved (each file''s place in the case''s list); '// &
            'rename the column with columns = ...'
      return
    end if
    call declared_units(spec, plan, msg)
    if (len_trim(msg) > 0) return
    do k = 1, ncol
      call unit_to_core(plan%declared(k), plan%factor(k), plan%offset(k), plan%unit(k), &
                        status, msg)
      if (status /= MLID_OK) then
        msg = 'column '//trim(label(plan, k))//': '//trim(msg)
        return
      end if
    end do
    do k = 1, nder
      call derive(spec%derived(k)%s, ncol + k, plan, status, msg)
      if (status /= MLID_OK) return
    end do
    plan%shown = plan%declared
    plan%dscale = plan%factor
    plan%doffset = plan%offset
    call shown_units(spec, plan, status, msg)
    if (status /= MLID_OK) return
    call pick_channels(spec, plan, status, msg)
  end subroutine make_plan

  !> 'NAME = unit' entries: each names a column, whose header may not say
  !> otherwise.
  subroutine declared_units(spec, plan, msg)
    type(channels_t), intent(in) :: spec
    type(plan_t), intent(inout) :: plan
    character(len=*), intent(out) :: msg
    character(len=NAMELEN) :: name
    character(len=:), allocatable :: rhs
    integer :: k, i

    msg = ''
    if (.not. allocated(spec%units)) return
    do k = 1, size(spec%units)
      call named_entry(spec%units(k)%s, 'units', plan, plan%ncol, name, rhs, i, msg)
      if (i == 0) return
      if (len_trim(plan%declared(i)) > 0 .and. to_lower(plan%declared(i)) /= to_lower(rhs)) then
        msg = 'units: '//trim(name)//' is declared in '//rhs//' but the file says '// &
              trim(plan%declared(i))
        return
      end if
      plan%declared(i) = rhs
    end do
  end subroutine declared_units

  !> An entry 'NAME = value' of list what (units, show): the channel it
  !> names among the first n (i; 0, with msg, when there is none) and the value.
  subroutine named_entry(entry, what, plan, n, name, rhs, i, msg)
    character(len=*), intent(in) :: entry, what
    type(plan_t), intent(in) :: plan
    integer, intent(in) :: n
    character(len=NAMELEN), intent(out) :: name
    character(len=:), allocatable, intent(out) :: rhs
    integer, intent(out) :: i
    character(len=*), intent(out) :: msg
    integer :: status
    i = 0
    call split_definition(entry, name, rhs, status, msg)
    if (status == MLID_OK) call find(plan, name, n, i, msg)
    if (i == 0) then
      msg = what//': '//trim(msg)
      return
    end if
    rhs = trim(adjustl(rhs))
  end subroutine named_entry

  !> 'NAME = unit' entries of show: the unit a channel (a column or a
  !> derived one) is shown in, instead of the one declared.  Display only:
  !> the values taken stay in the core's unit.  The channel's core unit must
  !> be known (a unit declared) and the same as the shown unit's.
  subroutine shown_units(spec, plan, status, msg)
    type(channels_t), intent(in) :: spec
    type(plan_t), intent(inout) :: plan
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=NAMELEN) :: name
    character(len=UNITLEN) :: core
    character(len=:), allocatable :: rhs, is_in
    real(wp) :: factor, offset
    integer :: k, i

    status = MLID_OK
    msg = ''
    if (.not. allocated(spec%show)) return
    do k = 1, size(spec%show)
      status = MLID_ERR_INPUT
      call named_entry(spec%show(k)%s, 'show', plan, size(plan%name), name, rhs, i, msg)
      if (i == 0) return
      call unit_to_core(rhs, factor, offset, core, status, msg)
      if (status /= MLID_OK) then
        msg = 'show '//trim(name)//': '//trim(msg)
        return
      end if
      status = MLID_ERR_INPUT
      is_in = trim(plan%declared(i))
      if (len(is_in) == 0) is_in = trim(plan%unit(i))
      if (len(is_in) == 0) then
        msg = 'show '//trim(name)//' = '//rhs//': '//trim(name)//' has no unit declared '// &
              '(declare it: units = '''//trim(name)//' = unit'' or '//trim(name)//'[unit])'
        return
      end if
      if (core /= plan%unit(i)) then
        msg = 'show '//trim(name)//' = '//rhs//': '//trim(name)//' is in '//is_in//', '// &
              rhs//' converts to '//core_name(core)//', not '//core_name(plan%unit(i))
        return
      end if
      plan%shown(i) = rhs
      plan%dscale(i) = factor
      plan%doffset(i) = offset
      status = MLID_OK
    end do
  end subroutine shown_units

  !> A core unit for a message: '' is dimensionless.
  function core_name(unit) result(text)
    character(len=*), intent(in) :: unit
    character(len=:), allocatable :: text
    text = trim(unit)
    if (len(text) == 0) text = 'dimensionless'
  end function core_name

  !> Derived channel j of the plan from its definition 'NAME = expression'.
  subroutine derive(def, j, plan, status, msg)
    character(len=*), intent(in) :: def
    integer, intent(in) :: j
    type(plan_t), intent(inout) :: plan
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=:), allocatable :: rhs
    integer, allocatable :: uses(:)
    integer :: i, k

    call split_definition(def, plan%name(j), rhs, status, msg)
    if (status /= MLID_OK) then
      msg = 'derived: '//trim(msg)
      return
    end if
    call find(plan, plan%name(j), j - 1, i, msg)
    if (i > 0) then
      status = MLID_ERR_INPUT
      msg = 'derived: a channel named '//trim(plan%name(j))//' exists already'
      return
    end if
    call smoothing_op(rhs, j, plan, status, msg)
    if (status /= MLID_OK) then
      msg = 'derived '//trim(plan%name(j))//': '//trim(msg)
      return
    end if
    if (plan%op(j - plan%ncol) == 0) then
      call expr_compile(rhs, plan%name(1:j - 1), plan%expr(j - plan%ncol), status, msg)
      if (status /= MLID_OK) then
        msg = 'derived '//trim(plan%name(j))//': '//trim(msg)
        return
      end if
    end if
    uses = uses_of(plan, j)
    do k = 1, size(uses)
      call mark(plan, uses(k))
    end do
    plan%factor(j) = 1.0_wp
    plan%offset(j) = 0.0_wp
    plan%unit(j) = ''
    plan%declared(j) = ''
    if (size(uses) == 0) return
    if (all(plan%unit(uses) == plan%unit(uses(1)))) plan%unit(j) = plan%unit(uses(1))
    if (all(plan%declared(uses) == plan%declared(uses(1)))) &
      plan%declared(j) = plan%declared(uses(1))
    if (len_trim(plan%unit(j)) > 0 .and. len_trim(plan%declared(j)) > 0) &
      plan%factor(j) = plan%factor(uses(1))
    if (is_rate(plan%op(j - plan%ncol))) then  ! per second, shown in the core's unit
      plan%declared(j) = ''
      plan%factor(j) = 1.0_wp
      if (index(plan%unit(j), '/s', back=.true.) == len_trim(plan%unit(j)) - 1 .and. &
          len_trim(plan%unit(j)) > 2) then
        plan%unit(j) = trim(plan%unit(j))//'2'      ! rad/s -> rad/s2, m/s -> m/s2
      else if (len_trim(plan%unit(j)) > 0) then
        plan%unit(j) = trim(plan%unit(j))//'/s'
      end if
    end if
  end subroutine derive

  !> 'F(NAME)' for F in SMOOTHERS, or with a cut-off in Hz 'deriv(NAME,
  !> 2.5)' (the Fourier ones only), over the file's whole record as read,
  !> sets derived channel j's op and source; any other use of them (inside
  !> an expression, or of an expression) is refused; anything else is an
  !> expression (op 0).
  subroutine smoothing_op(rhs, j, plan, status, msg)
    character(len=*), intent(in) :: rhs
    integer, intent(in) :: j
    type(plan_t), intent(inout) :: plan
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=:), allocatable :: text, arg
    integer :: op, i, comma, ios
    real(wp) :: fc
    status = MLID_OK
    msg = ''
    text = to_lower(trim(adjustl(rhs)))
    op = 0
    do i = 1, size(SMOOTHERS)
      if (index(text, trim(SMOOTHERS(i))//'(') == 1) op = i
    end do
    status = MLID_ERR_INPUT
    if (op == 0) then
      do i = 1, size(SMOOTHERS)
        if (uses_call(text, trim(SMOOTHERS(i))//'(')) then
          msg = trim(SMOOTHERS(i))//'() makes a channel of its own: write NAME = '// &
                trim(SMOOTHERS(i))//'(CHANNEL) on a line of its own'
          return
        end if
      end do
      status = MLID_OK
      return
    end if
    if (text(len(text):) /= ')') then
      msg = trim(SMOOTHERS(op))//'() takes one channel''s name: '//SMOOTHERS_USE
      return
    end if
    arg = trim(adjustl(rhs))
    arg = arg(index(arg, '(') + 1:len(arg) - 1)
    comma = index(arg, ',')
    if (comma > 0 .and. op > 2) then
      msg = trim(SMOOTHERS(op))//'(): '//LOCAL_NO_CUTOFF
      return
    else if (comma > 0) then                 ! NAME, cut-off in Hz
      read (arg(comma + 1:), *, iostat=ios) fc
      if (ios /= 0 .or. .not. fc > 0.0_wp .or. fc > huge(fc)) then
        msg = 'the cut-off in '''//trim(adjustl(rhs))//''' must be a frequency > 0 in Hz'
        return
      end if
      plan%fc(j - plan%ncol) = fc
      arg = arg(1:comma - 1)
    end if
    arg = trim(adjustl(arg))
    if (len(arg) == 0 .or. verify(arg, 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_') &
        /= 0) then
      msg = trim(SMOOTHERS(op))//'() takes one channel''s name, not '''//arg// &
            ''' (define an expression as a derived channel first): '//SMOOTHERS_USE
      return
    end if
    call find(plan, arg, j - 1, i, msg)
    if (i == 0) return
    plan%op(j - plan%ncol) = op
    plan%src(j - plan%ncol) = i
    status = MLID_OK
  end subroutine smoothing_op

  !> Whether smoothing op gives a derivative (SMOOTHERS' even places).
  pure logical function is_rate(op)
    integer, intent(in) :: op
    is_rate = op > 0 .and. mod(op, 2) == 0
  end function is_rate

  !> Whether text calls the function whose 'name(' is given (not as the tail of a longer name).
  logical function uses_call(text, name)
    character(len=*), intent(in) :: text, name
    integer :: at, from
    character :: before
    uses_call = .false.
    from = 1
    do
      at = index(text(from:), name)
      if (at == 0) return
      at = at + from - 1
      before = ' '
      if (at > 1) before = text(at - 1:at - 1)
      if (verify(before, 'abcdefghijklmnopqrstuvwxyz0123456789_') /= 0) then
        uses_call = .true.
        return
      end if
      from = at + 1
    end do
  end function uses_call

  !> The channels derived channel i (> ncol) is computed from.
  function uses_of(plan, i) result(uses)
    type(plan_t), intent(in) :: plan
    integer, intent(in) :: i
    integer, allocatable :: uses(:)
    if (plan%op(i - plan%ncol) > 0) then
      uses = [plan%src(i - plan%ncol)]
    else
      uses = expr_uses(plan%expr(i - plan%ncol))
    end if
  end function uses_of

  !> A channel needed, and the columns a derived channel is computed from.
  recursive subroutine mark(plan, i)
    type(plan_t), intent(inout) :: plan
    integer, intent(in) :: i
    integer, allocatable :: uses(:)
    integer :: k
    if (plan%need(i)) return
    plan%need(i) = .true.
    if (i <= plan%ncol) return
    uses = uses_of(plan, i)
    do k = 1, size(uses)
      call mark(plan, uses(k))
    end do
  end subroutine mark

  !> Time, inputs and outputs, each a column number or a channel name.
  subroutine pick_channels(spec, plan, status, msg)
    type(channels_t), intent(in) :: spec
    type(plan_t), intent(inout) :: plan
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=NAMELEN), allocatable :: want(:)
    integer :: k, i

    status = MLID_ERR_INPUT
    want = [spec%time, spec%inputs, spec%outputs]
    plan%nin = size(spec%inputs)
    allocate (plan%pick(size(want) - 1))
    do k = 1, size(want)
      if (is_number(want(k))) then
        read (want(k), *) i
        if (i < 1 .or. i > plan%ncol) then
          msg = 'column '//trim(adjustl(want(k)))//' requested, the file has columns 1 to '// &
                itoa(plan%ncol)
          return
        end if
      else
        call find(plan, want(k), size(plan%name), i, msg)
        if (i == 0) return
      end if
      call mark(plan, i)
      if (k == 1) then
        plan%itime = i
        call time_unit_check(plan, i, msg)
        if (len_trim(msg) > 0) return
      else
        plan%pick(k - 1) = i
      end if
    end do
    status = MLID_OK
    msg = ''
  end subroutine pick_channels

  !> The time channel i's unit, if one is declared, must convert to s: a
  !> time in kt or deg would be scaled as if it were one (message, else '').
  !> One declared as none ('-' or '1': its core unit is '') is read as it is.
  subroutine time_unit_check(plan, i, msg)
    type(plan_t), intent(in) :: plan
    integer, intent(in) :: i
    character(len=*), intent(out) :: msg
    character(len=:), allocatable :: is_in
    msg = ''
    if (plan%unit(i) == 's' .or. len_trim(plan%unit(i)) == 0) return
    is_in = trim(plan%declared(i))
    if (len(is_in) == 0) is_in = trim(plan%unit(i))
    msg = 'time channel '//label(plan, i)//' is in '//is_in//', not a unit of time ('// &
          units_of('s')//')'
  end subroutine time_unit_check

  !> The channel named name among the first n of the plan: exactly, else
  !> case-insensitively when unique; 0 and a message when there is none.
  subroutine find(plan, name, n, i, msg)
    type(plan_t), intent(in) :: plan
    character(len=*), intent(in) :: name
    integer, intent(in) :: n
    integer, intent(out) :: i
    character(len=*), intent(out) :: msg
    logical :: same(n)
    integer :: k

    msg = ''
    i = 0
    same = plan%name(1:n) == name
    if (count(same) == 0) same = to_lower(plan%name(1:n)) == to_lower(name)
    if (count(same) == 1) then
      i = findloc(same, .true., 1)
    else if (count(same) > 1) then
      msg = itoa(count(same))//' channels are named '//trim(name)
    else
      msg = 'no channel named '//trim(name)//' (channels: '
      do k = 1, min(n, 12)
        msg = trim(msg)//' '//trim(plan%name(k))
      end do
      if (n > 12) msg = trim(msg)//' ...'
      if (n == 0 .or. all(plan%name(1:n) == '')) msg = 'no channel named '//trim(name)// &
        ' (the file names no columns: name them with columns = ... or number them'
      msg = trim(msg)//')'
    end if
  end subroutine find

  !> Convert, derive, window and check; the set the case takes.
  subroutine take(plan, ch, line, where, lineword, t_start, t_end, dt, set, status, msg)
    type(plan_t), intent(in) :: plan
    real(wp), intent(inout) :: ch(:, :)
    integer, intent(in) :: line(:)
    character(len=*), intent(in) :: where, lineword
    real(wp), intent(in) :: t_start, t_end, dt
    type(channel_set_t), intent(out) :: set
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    logical, allocatable :: keep(:)
    integer :: k, r, at

    status = MLID_ERR_INPUT
    do k = 1, plan%ncol
      if (plan%need(k) .and. (plan%factor(k) /= 1.0_wp .or. plan%offset(k) /= 0.0_wp)) &
        ch(:, k) = plan%factor(k)*ch(:, k) + plan%offset(k)
    end do
    do k = plan%ncol + 1, size(plan%name)
      if (plan%op(k - plan%ncol) > 0) then
        if (.not. plan%need(k)) cycle
        call smoothed(plan, k, ch, dt, at, status, msg)
        if (status /= MLID_OK) then
          if (at > 0) then
            msg = where//' '//lineword//' '//itoa(line(at))//': derived channel '// &
                  trim(plan%name(k))//': '//trim(msg)
          else
            msg = where//': derived channel '//trim(plan%name(k))//': '//trim(msg)
          end if
          status = MLID_ERR_INPUT
          return
        end if
        status = MLID_ERR_INPUT
      else
        call expr_eval(plan%expr(k - plan%ncol), ch(:, 1:k - 1), ch(:, k))
      end if
      if (.not. plan%need(k) .or. all(ieee_is_finite(ch(:, k)))) cycle
      r = findloc(ieee_is_finite(ch(:, k)), .false., 1)
      msg = where//' '//lineword//' '//itoa(line(r))//': derived channel '// &
            trim(plan%name(k))//' is not finite'
      return
    end do
    keep = ch(:, plan%itime) >= t_start .and. ch(:, plan%itime) <= t_end
    if (count(keep) == 0) then
      msg = where//': no samples between '//seconds(t_start)//' and '//seconds(t_end)// &
            ' (the record runs from '//seconds(ch(1, plan%itime))//' to '// &
            seconds(ch(size(ch, 1), plan%itime))//')'
      return
    end if
    set%t = pack(ch(:, plan%itime), keep)
    if (dt > 0.0_wp) set%t = set%t(1) + dt*[(real(k - 1, wp), k=1, size(set%t))]
    set%line = pack(line, keep)
    call record_check_time(set%t, at, status, msg)
    if (status /= MLID_OK) then
      msg = where//' '//lineword//' '//itoa(set%line(at))//': '//trim(msg)
      return
    end if
    allocate (set%u(plan%nin, size(set%t)), set%y(size(plan%pick) - plan%nin, size(set%t)))
    do k = 1, plan%nin
      set%u(k, :) = pack(ch(:, plan%pick(k)), keep)
    end do
    do k = plan%nin + 1, size(plan%pick)
      set%y(k - plan%nin, :) = pack(ch(:, plan%pick(k)), keep)
    end do
    set%names = plan%name(plan%pick)
    set%units = plan%unit(plan%pick)
    set%shown = plan%shown(plan%pick)
    set%scale = plan%dscale(plan%pick)
    set%offset = plan%doffset(plan%pick)
    call radians_check(plan, set, where, msg)
  end subroutine take

  !> Derived channel k = its smoothing function of its source over the
  !> whole record read, at the step dt when the deck rebuilds the time
  !> (dt > 0), else at the time channel's, which must be uniform and
  !> computed before k.
  subroutine smoothed(plan, k, ch, dt, at, status, msg)
    type(plan_t), intent(in) :: plan
    integer, intent(in) :: k
    real(wp), intent(inout) :: ch(:, :)
    real(wp), intent(in) :: dt
    integer, intent(out) :: at               !< the sample a non-uniform step ends at, else 0
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: xs(:), xd(:)
    real(wp) :: step, fc
    integer :: kc, op, src
    status = MLID_ERR_INPUT
    at = 0
    step = dt
    if (step <= 0.0_wp) then
      if (plan%itime >= k) then
        msg = 'the time channel '//trim(plan%name(plan%itime))//' must be a column or a '// &
              'derived channel defined before it'
        return
      end if
      call smooth_uniform_check(ch(:, plan%itime), step, at, msg)
      if (at > 0) return
    end if
    op = plan%op(k - plan%ncol)
    src = plan%src(k - plan%ncol)
    allocate (xs(size(ch, 1)), xd(size(ch, 1)))
    select case (op)
    case (1, 2)
      call smooth_fourier(ch(:, src), step, xs, xd, kc, fc, status, msg, plan%fc(k - plan%ncol))
    case (3)
      call smooth_local(ch(:, src), xs, status, msg)
    case default
      call deriv_local(ch(:, src), step, xd, status, msg)
    end select
    if (status /= MLID_OK) return
    if (is_rate(op)) then
      ch(:, k) = xd
    else
      ch(:, k) = xs
    end if
  end subroutine smoothed

  !> A channel declared in rad whose values go beyond 2 pi in magnitude
  !> most likely holds degrees: a warning (status stays OK) naming the one
  !> that goes furthest, its largest value, and the others, if any.
  subroutine radians_check(plan, set, where, msg)
    type(plan_t), intent(in) :: plan
    type(channel_set_t), intent(in) :: set
    character(len=*), intent(in) :: where
    character(len=*), intent(out) :: msg
    real(wp), parameter :: TWO_PI = 2.0_wp*acos(-1.0_wp)
    character(len=:), allocatable :: others
    real(wp) :: worst, v
    integer :: k, p, at, iworst

    msg = ''
    others = ''
    worst = 0.0_wp
    iworst = 0
    do k = 1, size(plan%pick)
      p = plan%pick(k)
      if (plan%unit(p) /= 'rad' .or. plan%factor(p) /= 1.0_wp .or. &
          len_trim(plan%declared(p)) == 0) cycle
      if (k <= plan%nin) then
        at = maxloc(abs(set%u(k, :)), 1)
        v = set%u(k, at)
      else
        at = maxloc(abs(set%y(k - plan%nin, :)), 1)
        v = set%y(k - plan%nin, at)
      end if
      if (abs(v) <= TWO_PI) cycle
      if (iworst > 0) then
        if (abs(v) <= abs(worst)) then
          call add(plan%name(p))
          cycle
        end if
        call add(plan%name(iworst))
      end if
      iworst = p
      worst = v
    end do
    if (iworst == 0) return
    msg = 'warning: '//where//': channel '//trim(plan%name(iworst))//' is declared in rad '// &
          'but reaches '//number_text(worst)//', beyond 2 pi: most likely degrees, declare it deg'
    if (len(others) > 0) msg = trim(msg)//' (so do '//others(3:)//')'
  contains
    subroutine add(name)             ! the message keeps to one line of msg_len
      character(len=*), intent(in) :: name
      if (len(others) < 48) then
        others = others//', '//trim(name)
      else if (others(len(others) - 2:) /= '...') then
        others = others//', ...'
      end if
    end subroutine add
  end subroutine radians_check

  !> A column number: digits, perhaps signed (a sign is refused as out of range).
  logical function is_number(text)
    character(len=*), intent(in) :: text
    integer :: k
    k = verify(text, ' ')
    is_number = .false.
    if (k == 0) return
    if (scan(text(k:k), '+-') == 1) k = k + 1
    is_number = len_trim(text) >= k .and. verify(trim(text(k:)), '0123456789') == 0
  end function is_number

  !> 'ALCG[deg]' -> ALCG, deg; 'ALCG' -> ALCG, unit unchanged.
  subroutine name_and_unit(text, name, unit)
    character(len=*), intent(in) :: text
    character(len=NAMELEN), intent(out) :: name
    character(len=UNITLEN), intent(inout) :: unit
    integer :: b, e
    b = index(text, '[')
    e = len_trim(text)
    if (b > 1 .and. text(e:e) == ']') then
      name = adjustl(text(1:b - 1))
      unit = adjustl(text(b + 1:e - 1))
    else
      name = adjustl(text)
    end if
  end subroutine name_and_unit

  !> A .mat, .h5 or .hdf5 file, by its name.
  logical function binary_format(path)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: p
    p = to_lower(trim(path))
    binary_format = ends(p, '.mat') .or. ends(p, '.h5') .or. ends(p, '.hdf5')
  contains
    logical function ends(s, tail)
      character(len=*), intent(in) :: s, tail
      ends = len(s) >= len(tail)
      if (ends) ends = s(len(s) - len(tail) + 1:) == tail
    end function ends
  end function binary_format

  !> A column for a message: its name, or its number.
  function label(plan, k) result(text)
    type(plan_t), intent(in) :: plan
    integer, intent(in) :: k
    character(len=:), allocatable :: text
    text = trim(plan%name(k))
    if (len(text) == 0) text = itoa(k)
  end function label

end module mlid_channels
