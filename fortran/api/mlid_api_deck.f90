!> The flat interface's handles, decks and records: a handle (mlid_handles)
!> per deck or record read, its cases' parts, the channels a case or a
!> file gives, and running a case's core job.
!>
!> Conventions of every mlid_api_* module (f2py wraps them all as
!> mlid._core; python/mlid/_bridge.py joins them into one interface):
!> explicit-shape arrays of C kinds, a status code and a message out.
!>   mkind, nx, nu, ny, nw   model kind (mlid_model_factory), sizes, noise inputs
!>   theta(nth)              all parameters [p, x0, bias, q, r, s] (mlid_models)
!>   isfree(nth)             a free parameter's place in the order of free (1, 2, ...), 0 fixed
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
  use mlid_deck, only: deck_read, deck_groups
  use mlid_handles, only: session_t, handle_new, handle_session, call_session, handle_free
  use mlid_case, only: case_t, case_values, case_uses, NAMELEN, CONDITION_NAMES
  use mlid_text, only: join_lines, split_lines, joined
  use mlid_sampling, only: record_check_segments
  use mlid_channels, only: channels_t, channel_set_t, channels_spec, channels_read, channels_table
  use mlid_units, only: UNITLEN
  use mlid_run, only: run_case, around_t, case_run_t
  use mlid_gil, only: gil_release, gil_restore
  use mlid_named, only: named_t, VALUE_REAL, VALUE_INT, VALUE_TEXT
  use mlid_progress, only: progress_read
  implicit none
  private
  public :: mlid_handle_new, mlid_handle_free, mlid_deck_open, mlid_condition_names, &
            mlid_values_sizes, mlid_values, mlid_deck_case_record, mlid_channels_read, &
            mlid_channels_table, mlid_channels_get, mlid_deck_case_run, mlid_check_time, &
            mlid_case_uses, mlid_deck_groups, mlid_progress_get

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
    integer :: k
    ncases = 0
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call deck_read(path, s%cases, status, msg)
    if (allocated(s%runs)) deallocate (s%runs)
    if (allocated(s%values)) deallocate (s%values)
    ! a run per case, here: two threads may run two cases of the deck at once
    allocate (s%runs(size(s%cases)), s%values(size(s%cases)))
    do k = 1, size(s%cases)                ! once: Python reads each case so
      call case_values(s%cases(k), s%values(k))
    end do
    ncases = size(s%cases)
  end subroutine mlid_deck_open

  !> The deck's groups, a line each: 'group|jobs that read it|its names'
  !> (mlid_deck's table, from which the deck reference is made).
  subroutine mlid_deck_groups(text)
    character(len=2048), intent(out) :: text
    text = deck_groups()
  end subroutine mlid_deck_groups

  !> The numeric flight-condition items of &case (mlid_case), comma-separated.
  subroutine mlid_condition_names(names)
    character(len=128), intent(out) :: names
    names = joined(CONDITION_NAMES)
  end subroutine mlid_condition_names

  !> Read data file j of estimate case k of handle h as the case takes it
  !> (channels, units, derived channels, units shown, window) and keep it in
  !> handle out for mlid_channels_get (its own: the cases of a deck share h,
  !> and may be read from several threads); a warning as mlid_channels_read
  !> gives it.
  subroutine mlid_deck_case_record(h, k, j, out, nt, status, msg)
    integer(c_int64_t), intent(in) :: h, out
    integer(c_int), intent(in) :: k, j
    integer(c_int), intent(out) :: nt, status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s, o
    type(case_t), pointer :: c
    nt = 0
    if (.not. has_file(h, k, j, s, c, status, msg)) return
    call handle_session(out, o, status, msg)
    if (status /= MLID_OK) return
    call channels_read(c%data_files(j), c%chan, c%win_start(j), c%win_end(j), o%taken, status, &
                       msg, manoeuvre=c%file_no(j))
    nt = taken_samples(o%taken, status)
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

  !> How much case k of handle h holds by name (which = 'case': the case as
  !> read, mlid_case's case_values; 'run': what its last run kept, a fit's
  !> numbers, mlid_run's put_fit): m values, n numbers, nt characters of
  !> names (one a line) and texts.
  subroutine mlid_values_sizes(h, k, which, m, n, nt)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    character(len=*), intent(in) :: which
    integer(c_int), intent(out) :: m, n, nt
    type(named_t), pointer :: v
    m = 0
    n = 0
    nt = 0
    v => values_of(h, k, which)
    if (.not. associated(v)) return
    call packed_sizes(v, m, n, nt)
  end subroutine mlid_values_sizes

  !> Those values, packed: value j is the j-th name of text (the names one a
  !> line, then the texts), of kind kinds(j) (mlid_named's VALUE_*), rank
  !> shapes(1, j) and shape shapes(2:, j) (a text: its length); its numbers
  !> follow the values before it in values, its characters (codes) the texts
  !> before it.  Sizes from mlid_values_sizes; other sizes give nothing.
  subroutine mlid_values(h, k, which, m, n, nt, kinds, shapes, values, text)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k, m, n, nt
    character(len=*), intent(in) :: which
    integer(c_int), intent(out) :: kinds(m), shapes(4, m), text(nt)
    real(c_double), intent(out) :: values(n)
    type(named_t), pointer :: v
    integer :: mm, nn, ntt
    kinds = 0
    shapes = 0
    values = 0.0_wp
    text = 0
    v => values_of(h, k, which)
    if (.not. associated(v)) return
    call packed_sizes(v, mm, nn, ntt)
    if (mm /= m .or. nn /= n .or. ntt /= nt) return
    call pack_values(v, kinds, shapes, values, text)
  end subroutine mlid_values

  !> The values 'case' or 'run' of case k of handle h, or 'call': what the
  !> handle's last call gave; null when none.
  function values_of(h, k, which) result(v)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    character(len=*), intent(in) :: which
    type(named_t), pointer :: v
    type(session_t), pointer :: s
    integer :: status
    character(len=64) :: msg
    v => null()
    if (which == 'call') then       ! what the handle's last call gave (k is not used)
      call handle_session(h, s, status, msg)
      if (status == MLID_OK) v => s%results
      return
    end if
    if (.not. associated(case_at(h, k))) return
    call handle_session(h, s, status, msg)
    select case (which)
    case ('case')
      v => s%values(k)
    case ('run')
      if (allocated(s%runs)) v => s%runs(k)%results
    end select
  end function values_of

  subroutine packed_sizes(v, m, n, nt)
    type(named_t), intent(in) :: v
    integer, intent(out) :: m, n, nt
    integer :: j
    m = v%n
    n = 0
    nt = 0
    do j = 1, v%n
      nt = nt + len(v%v(j)%name) + 1
      select case (v%v(j)%kind)
      case (VALUE_REAL)
        n = n + size(v%v(j)%r)
      case (VALUE_INT)
        n = n + size(v%v(j)%i)
      case (VALUE_TEXT)
        nt = nt + len(v%v(j)%t)
      end select
    end do
  end subroutine packed_sizes

  subroutine pack_values(v, kinds, shapes, values, text)
    type(named_t), intent(in) :: v
    integer(c_int), intent(out) :: kinds(:), shapes(:, :), text(:)
    real(c_double), intent(out) :: values(:)
    character(len=:), allocatable :: names, texts
    integer :: j, at
    at = 0
    names = ''
    texts = ''
    do j = 1, v%n
      associate (x => v%v(j))
        kinds(j) = x%kind
        shapes(1, j) = x%rank
        shapes(2:, j) = x%shape
        names = names//x%name//achar(10)
        select case (x%kind)
        case (VALUE_REAL)
          values(at + 1:at + size(x%r)) = x%r
          at = at + size(x%r)
        case (VALUE_INT)
          values(at + 1:at + size(x%i)) = real(x%i, wp)
          at = at + size(x%i)
        case (VALUE_TEXT)
          shapes(1, j) = 0
          shapes(2, j) = len(x%t)
          texts = texts//x%t
        end select
      end associate
    end do
    names = names//texts
    do j = 1, len(names)
      text(j) = ichar(names(j:j))
    end do
  end subroutine pack_values

  !> Read a record's channels (mlid_channels: text, or a .mat or HDF5 file)
  !> from the handle's given values (mlid_api_values): path, variable
  !> (naming its matrix when it holds several, '' for none), skip_rows and
  !> the spec (given_spec); keep them in handle h for mlid_channels_get.
  !> Status OK with msg 'warning: ...' when a channel looks wrong for its
  !> declared unit (degrees in rad).
  subroutine mlid_channels_read(h, nt, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: nt, status
    character(len=256), intent(out) :: msg
    type(channels_t) :: spec
    type(session_t), pointer :: s
    character(len=:), allocatable :: path, variable
    real(wp) :: t_start, t_end
    integer :: skip_rows
    nt = 0
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call s%given%get('path', path, status, msg)
    call s%given%get('variable', variable, status, msg)
    call s%given%get('skip_rows', skip_rows, status, msg)
    if (status /= MLID_OK) return
    call given_spec(s%given, skip_rows, spec, t_start, t_end, status, msg)
    spec%variable = variable
    if (status == MLID_OK) then
      call channels_read(path, spec, t_start, t_end, s%taken, status, msg)
    else
      msg = 'data file '//trim(path)//': '//trim(msg)
    end if
    nt = taken_samples(s%taken, status)
  end subroutine mlid_channels_read

  !> The same for a table x(nrow, ncol) the Python front end read, with
  !> given values source (what messages call it), names and col_units (its
  !> columns', one a line) and the spec (given_spec).
  subroutine mlid_channels_table(h, nrow, ncol, x, nt, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: nrow, ncol
    real(c_double), intent(in) :: x(nrow, ncol)
    integer(c_int), intent(out) :: nt, status
    character(len=256), intent(out) :: msg
    type(channels_t) :: spec
    type(session_t), pointer :: s
    character(len=:), allocatable :: source, names, col_units
    real(wp) :: t_start, t_end
    nt = 0
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    call s%given%get('source', source, status, msg)
    call s%given%get('names', names, status, msg)
    call s%given%get('col_units', col_units, status, msg)
    if (status /= MLID_OK) return
    call given_spec(s%given, 0, spec, t_start, t_end, status, msg)
    if (status == MLID_OK) then
      call channels_table(source, x, split_lines(names, ncol, NAMELEN), &
                          split_lines(col_units, ncol, UNITLEN), spec, t_start, t_end, s%taken, &
                          status, msg)
    else
      msg = 'data '//trim(source)//': '//trim(msg)
    end if
    nt = taken_samples(s%taken, status)
  end subroutine mlid_channels_table

  !> The channel spec of given values g, as channels_spec takes it: time,
  !> inputs, outputs, columns, units, derived, show (one entry a line); the
  !> window t_start, t_end and dt (> 0: a uniform step replacing the time).
  subroutine given_spec(g, skip_rows, spec, t_start, t_end, status, msg)
    type(named_t), intent(in) :: g
    integer, intent(in) :: skip_rows
    type(channels_t), intent(out) :: spec
    real(wp), intent(out) :: t_start, t_end
    integer(c_int), intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=:), allocatable :: time, inputs, outputs, columns, units, derived, show
    real(wp) :: dt
    status = MLID_OK
    msg = ''
    call g%get('time', time, status, msg)
    call g%get('inputs', inputs, status, msg)
    call g%get('outputs', outputs, status, msg)
    call g%get('columns', columns, status, msg)
    call g%get('units', units, status, msg)
    call g%get('derived', derived, status, msg)
    call g%get('show', show, status, msg)
    call g%get('t_start', t_start, status, msg)
    call g%get('t_end', t_end, status, msg)
    call g%get('dt', dt, status, msg)
    if (status /= MLID_OK) return
    call channels_spec(time, inputs, outputs, columns, units, derived, show, skip_rows, spec, &
                       status, msg)
    spec%dt = dt
  end subroutine given_spec

  !> The channels handle h took last: t(nt), u(nu, nt), y(ny, nt), the
  !> file line (or table row) of each sample; and in h's results, per
  !> channel (inputs, then outputs), names, units (the core's) and shown
  !> (the units declared), one a line, and scale and offset: core =
  !> scale*declared + offset.  Sizes other than those taken: an error.
  subroutine mlid_channels_get(h, nu, ny, nt, t, u, y, line, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: nu, ny, nt
    real(c_double), intent(out) :: t(nt), u(nu, nt), y(ny, nt)
    integer(c_int), intent(out) :: line(nt), status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    t = 0.0_wp
    u = 0.0_wp
    y = 0.0_wp
    line = 0
    call call_session(h, s, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    msg = 'not the sizes of the channels taken last'
    if (.not. allocated(s%taken%t)) return
    if (size(s%taken%t) /= nt .or. size(s%taken%u, 1) /= nu .or. size(s%taken%y, 1) /= ny) return
    status = MLID_OK
    msg = ''
    t = s%taken%t
    u = s%taken%u
    y = s%taken%y
    line = s%taken%line
    call s%results%put('names', join_lines(s%taken%names))
    call s%results%put('units', join_lines(s%taken%units))
    call s%results%put('shown', join_lines(s%taken%shown))
    call s%results%put('scale', s%taken%scale)
    call s%results%put('offset', s%taken%offset)
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
  !> files written (its fit with the GIL released: run_case's hooks); kept
  !> in h for mlid_values (which = 'run'), whole: its
  !> report lines ('report'), JSON object ('json'), notes one a line
  !> ('notes'), and a fit's numbers.  status, msg: the case's.
  subroutine mlid_deck_case_run(h, k, p, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    integer(c_int64_t), intent(in) :: p      !< a handle to count the run's progress in, or 0
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s, ps
    type(case_t), pointer :: c
    type(case_t) :: work
    type(case_run_t) :: run
    character(len=:), allocatable :: text
    integer :: j
    c => case_at(h, k)
    call no_case(c, status, msg)
    if (status /= MLID_OK) return
    call handle_session(h, s, status, msg)
    work = c
    ! into a run of its own, kept when it ends: another thread may run case k
    ! of this handle while this one's fit runs without the GIL
    if (p == 0) then
      call run_case(work, run, around_t(gil_release, gil_restore))
    else
      call handle_session(p, ps, status, msg)
      if (status /= MLID_OK) return
      call run_case(work, run, around_t(gil_release, gil_restore), ps%progress)
    end if
    s%runs(k) = run
    associate (r => s%runs(k))
      status = r%status
      msg = r%msg
      text = ''
      do j = 1, size(r%notes)
        text = text//r%notes(j)%s//achar(10)
      end do
      call r%results%put('report', r%report)
      call r%results%put('json', r%json)
      call r%results%put('notes', text)
    end associate
  end subroutine mlid_deck_case_run

  !> How far the long work of the call given handle p for its progress
  !> is (mlid_progress): what runs (label), done of total (the end when
  !> exact is 1, a ceiling otherwise), running (active 1), and its phase
  !> (one more for each new piece of work).  Read from another thread while
  !> that call runs without the GIL; all 0 for a handle that is none.
  subroutine mlid_progress_get(p, label, done, total, exact, active, phase)
    integer(c_int64_t), intent(in) :: p
    character(len=48), intent(out) :: label   !< mlid_progress's LABEL_LEN (f2py needs the number)
    integer(c_int), intent(out) :: done, total, exact, active, phase
    type(session_t), pointer :: s
    integer :: status
    character(len=64) :: msg
    label = ''
    done = 0
    total = 0
    exact = 0
    active = 0
    phase = 0
    call handle_session(p, s, status, msg)
    if (status /= MLID_OK) return
    call progress_read(s%progress, label, done, total, exact, active, phase)
  end subroutine mlid_progress_get

  !> Whether case k of handle h reads or writes the file path (mlid_case's
  !> case_uses): 1 if it does, else 0 (also for no such case).
  subroutine mlid_case_uses(h, k, path, uses)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: k
    character(len=*), intent(in) :: path
    integer(c_int), intent(out) :: uses
    type(case_t), pointer :: c
    uses = 0
    c => case_at(h, k)
    if (associated(c)) uses = merge(1, 0, case_uses(c, path))
  end subroutine mlid_case_uses

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
