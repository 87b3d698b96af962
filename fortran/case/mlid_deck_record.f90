!> What the front ends ask of a case once it is read (mlid_deck): its
!> record from its data files, manoeuvre after manoeuvre (case_record), or
!> a simulate case's time base and inputs (case_time_input); whether its
!> corrected records can be written; its parameters laid out for several
!> manoeuvres (manoeuvre_layout, manoeuvre_block) and their units; and the
!> case that predicts a validate case's held-out manoeuvres (holdout_case).
submodule (mlid_deck) mlid_deck_record
  use mlid_files, only: temporary_for
  use mlid_case, only: MAXSEG
  use mlid_kinds, only: MLID_ERR_MEMORY
  use mlid_options, only: option_set
  use mlid_inputs, only: input_signal
  use mlid_signals, only: multisine_band, multisine, sweep, prbs, finish_signal, SIGNAL_SHAPES, &
                          MULTISINE_ITERATIONS
  use mlid_channels, only: channel_set_t, channels_read
  use mlid_record, only: record_t, record_read
  use mlid_sampling, only: record_check_time
  use mlid_param_units, only: param_units
  use mlid_params, only: no_ties, free_indices, manoeuvre_places
  use mlid_layout, only: layout_table_t, layout_of, manoeuvre_map, manoeuvre_suffix
  implicit none

contains

  !> The entries of theta's block key (laid out for nseg manoeuvres,
  !> manoeuvre_layout) that hold for manoeuvre j: its own, or the shared ones.
  module procedure manoeuvre_block
    type(layout_table_t) :: lt
    integer, allocatable :: map(:), seg(:)
    character(len=msg_len) :: iomsg
    integer :: b, ios, last
    allocate (v(0))
    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, ios, iomsg)
    if (ios /= MLID_OK) return
    call manoeuvre_map(lt, nseg, map, seg)
    b = findloc(lt%key, key, 1)
    if (b == 0 .or. size(map) /= size(theta)) return
    last = lt%nth                              ! the block ends where the next begins
    if (b < lt%nblock) last = lt%off(b + 1)
    v = pack(theta, map > lt%off(b) .and. map <= last .and. (seg == 0 .or. seg == j))
  end procedure manoeuvre_block

  !> Whether every corrected record's path can be written: both front ends
  !> ask before the fit, so that a typo does not cost one.
  module procedure corrected_writable
    character(len=:), allocatable :: tmp
    integer :: j
    status = MLID_OK
    msg = ''
    if (.not. allocated(c%corrected)) return
    do j = 1, size(c%corrected)
      call temporary_for(trim(c%corrected(j)), tmp, status, msg)
      if (status /= MLID_OK) return
    end do
  end procedure corrected_writable

  !> The record of an estimate case: time, inputs and outputs from its
  !> data files (paths resolved by the reader).  Several files are
  !> several manoeuvres, one after the other, each keeping its sampling with
  !> its times moved to follow the one before; segstart(k) is the first
  !> sample of manoeuvre k.  The reader's warnings (values that look wrong
  !> for their declared unit), one per file, in notes.
  module procedure case_record
    real(wp), allocatable :: tk(:), uk(:, :), yk(:, :)
    integer :: k, nseg
    integer :: starts(MAXSEG)

    nseg = size(c%data_files)
    allocate (t(0), u(c%nu, 0), y(c%ny, 0))
    if (present(notes)) allocate (notes(0))
    if (present(own_t)) allocate (own_t(0))
    do k = 1, nseg
      call read_record(c, k, tk, uk, yk, status, msg, units, names, shown, scale, progress)
      if (status /= MLID_OK) return
      if (present(notes) .and. len_trim(msg) > 0) call add_line(notes, msg)
      msg = ''
      if (size(tk) < 2 .and. nseg > 1) then
        status = MLID_ERR_INPUT
        write (msg, '(a,i0,a)') 'manoeuvre ', k, ' ('//trim(c%data_files(k))// &
          ') has fewer than 2 samples'
        return
      end if
      starts(k) = size(t) + 1
      if (present(own_t)) own_t = [own_t, tk]
      ! each manoeuvre follows the one before, in mlid/maneuvers.py's join's arithmetic
      if (k > 1) tk = tk + (t(size(t)) + (tk(2) - tk(1)) - tk(1))
      t = [t, tk]
      u = reshape([u, uk], [c%nu, size(t)])
      y = reshape([y, yk], [c%ny, size(t)])
    end do
    if (present(segstart)) segstart = starts(1:nseg)
  end procedure case_record

  !> Data file k: the case's channels of it in its window, by the one
  !> record reader.
  subroutine read_record(c, k, t, u, y, status, msg, units, names, shown, scale, progress)
    type(case_t), intent(in) :: c
    integer, intent(in) :: k
    real(wp), allocatable, intent(out) :: t(:), u(:, :), y(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=UNITLEN), allocatable, intent(inout), optional :: units(:), shown(:)
    character(len=NAMELEN), allocatable, intent(inout), optional :: names(:)
    real(wp), allocatable, intent(inout), optional :: scale(:)
    type(progress_t), intent(inout), optional :: progress
    type(channel_set_t) :: set
    call channels_read(c%data_files(k), c%chan, c%win_start(k), c%win_end(k), set, status, msg, &
                       manoeuvre=c%file_no(k), progress=progress)
    if (status /= MLID_OK) return
    if (present(units)) then           ! the first file's; every file declares the same
      if (.not. allocated(units)) units = set%units
    end if
    if (present(names)) then
      if (.not. allocated(names)) names = set%names
    end if
    if (present(shown)) then
      if (.not. allocated(shown)) shown = set%shown
    end if
    if (present(scale)) then
      if (.not. allocated(scale)) scale = set%scale
    end if
    call move_alloc(set%t, t)
    call move_alloc(set%u, u)
    call move_alloc(set%y, y)
  end subroutine read_record

  !> The case's parameters for nseg manoeuvres: every manoeuvre its own
  !> initial state and biases (the x0 and bias blocks repeated, start values
  !> and free flags alike), the rest shared; labels of a manoeuvre's own
  !> entries end in '#k'.  As mlid/maneuvers.py does for Python.
  module procedure manoeuvre_layout
    integer :: nth, k
    integer, allocatable :: map(:), seg(:), new_of(:), places(:)
    logical, allocatable :: own(:)
    character(len=NAMELEN), allocatable :: full(:), lab(:)
    type(layout_table_t) :: lt

    status = MLID_OK
    msg = ''
    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, status, msg)
    if (status /= MLID_OK) return
    if (nseg <= 1) then
      call own_initial_states()
      return
    end if
    call manoeuvre_map(lt, nseg, map, seg)
    places = manoeuvre_places(c%isfree, map, seg)
    nth = size(c%theta)
    allocate (own(nth), new_of(0:nth))
    own = .false.
    own(pack(map, seg > 0)) = .true.
    new_of = 0
    do k = size(map), 1, -1
      if (seg(k) == 0) new_of(map(k)) = k
    end do
    if (any(own(c%tie%to)) .or. any(own(c%tie%from))) then
      status = MLID_ERR_INPUT
      msg = 'ties to or from initial states and biases are not available with several manoeuvres'
      return
    end if
    allocate (full(nth))
    full = ''
    full(free_indices(c%isfree)) = c%labels
    if (c%use_prior == 1) then
      if (any(c%isfree > 0 .and. own)) then
        status = MLID_ERR_INPUT
        msg = 'a priori weighting with free initial states or biases is not available with '// &
              'several manoeuvres'
        return
      end if
    end if
    allocate (lab(size(map)))
    do k = 1, size(map)
      lab(k) = trim(full(map(k)))//trim(manoeuvre_suffix(seg(k), nseg))
    end do
    c%tie%to = new_of(c%tie%to)           ! tied entries and sources are shared ones
    c%tie%from = new_of(c%tie%from)
    c%tie%offset = c%tie%offset(map)
    c%theta = c%theta(map)
    if (allocated(c%prior)) c%prior = c%prior(map)
    if (allocated(c%lower)) c%lower = c%lower(map)
    if (allocated(c%upper)) c%upper = c%upper(map)
    if (allocated(c%pweight)) call grow_weight()
    c%isfree = places
    c%labels = lab(free_indices(c%isfree))
    call own_initial_states()

  contains

    !> Each manoeuvre's x0 from initial_states (the x0 blocks follow one
    !> another, manoeuvre by manoeuvre).
    subroutine own_initial_states()
      integer :: o
      if (.not. allocated(c%initial_states)) return
      if (size(c%initial_states) == 0) return
      if (size(c%initial_states) /= c%nx*nseg) then
        status = MLID_ERR_INPUT
        msg = 'initial_states has '//itoa(size(c%initial_states))//' values, not nx = '// &
              itoa(c%nx)//' for each of '//itoa(nseg)//' manoeuvres'
        return
      end if
      o = lt%off(findloc(lt%key, 'x0', 1))
      c%theta(o + 1:o + c%nx*nseg) = c%initial_states
    end subroutine own_initial_states

    !> The a priori weight over the new free set: shared entries keep
    !> theirs, a manoeuvre's own get none (none had one, checked above).
    subroutine grow_weight()
      real(wp), allocatable :: w(:, :)
      integer, allocatable :: old(:), newf(:)
      integer :: a, b, ia, ib
      old = free_indices(c%isfree)
      newf = free_indices(places)
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

  end procedure manoeuvre_layout

  !> The units of the case's free parameters on nseg manoeuvres, from its
  !> channels' units (inputs, then outputs); called before manoeuvre_layout.
  module procedure case_param_units
    type(layout_table_t) :: lt
    character(len=UNITLEN), allocatable :: each(:)
    integer, allocatable :: map(:), seg(:)

    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, status, msg)
    if (status /= MLID_OK) return
    allocate (each(size(c%theta)))
    call param_units(lt, c%theta, channel_units(1:c%nu), channel_units(c%nu + 1:c%nu + c%ny), each)
    call manoeuvre_map(lt, max(nseg, 1), map, seg)
    units = each(map(free_indices(manoeuvre_places(c%isfree, map, seg))))
  end procedure case_param_units

  !> The case that predicts the held-out manoeuvres of validate case c
  !> from its fit on nfit (theta_fit, in the layout of nfit manoeuvres):
  !> every parameter held at its estimate but the initial states and
  !> output biases that were free in the fit, fitted afresh on each held-out
  !> manoeuvre (start: the first fitted manoeuvre's); no ties, prior or
  !> bounds; output error on a model without noise, as a prediction is.
  !> One manoeuvre's layout (manoeuvre_layout spreads it over the held-out
  !> ones).  As python/mlid/report/validation.py does for Python.
  module procedure holdout_case
    type(layout_table_t) :: lt
    integer, allocatable :: map(:), seg(:)
    logical, allocatable :: own(:)
    character(len=NAMELEN), allocatable :: full(:)
    integer :: k, b, i0, i1

    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, status, msg)
    if (status /= MLID_OK) return
    call manoeuvre_map(lt, max(nfit, 1), map, seg)
    h = c
    do k = size(map), 1, -1
      if (seg(k) <= 1) h%theta(map(k)) = theta_fit(k)
    end do
    allocate (own(size(c%theta)), full(size(c%theta)))
    own = .false.
    do b = 1, lt%nblock
      i0 = lt%off(b) + 1
      i1 = lt%off(b) + lt%rows(b)*merge(1, lt%cols(b), lt%cols(b) < 0)
      if (any(lt%key(b) == [character(len=8) :: 'x0', 'bias'])) own(i0:i1) = .true.
      if (any(lt%key(b) == [character(len=8) :: 'q', 'r', 's'])) h%theta(i0:i1) = 0.0_wp
    end do
    full = ''
    full(free_indices(c%isfree)) = c%labels
    h%isfree = merge(c%isfree, 0, own)
    h%labels = full(free_indices(h%isfree))
    h%tie = no_ties(size(h%theta))
    h%use_prior = 0
    h%use_bounds = 0
    call option_set(h%iopt, h%ropt, 'method', 'output_error', status, msg)
    if (status == MLID_OK) call option_set(h%iopt, h%ropt, 'startup', 'none', status, msg)
    if (status == MLID_OK) call option_set(h%iopt, h%ropt, 'rank_min', '0', status, msg)
    if (status == MLID_OK) call option_set(h%iopt, h%ropt, 'rank_max', '0', status, msg)
  end procedure holdout_case

  !> Time base t = 0, dt, ..., and inputs of a simulate case; or, with
  !> input_file (simulate, monte_carlo), the file's time (column 1) and the
  !> nu columns after it.
  module procedure case_time_input
    type(record_t) :: rec
    integer :: nt, k, at

    if (len_trim(c%input_file) > 0) then
      allocate (t(0), u(c%nu, 0))
      call record_read(c%input_file, [(k, k=1, c%nu + 1)], 0, rec, status, msg)
      if (status /= MLID_OK) msg = 'input_file: '//trim(msg)
      if (status /= MLID_OK) return
      if (size(rec%x, 2) < 2) then
        status = MLID_ERR_INPUT
        msg = 'input_file '//trim(c%input_file)//': fewer than 2 samples'
        return
      end if
      call record_check_time(rec%x(1, :), at, status, msg)
      if (status /= MLID_OK) then
        msg = 'input_file '//trim(c%input_file)//' line '//itoa(rec%line(at))//': '//trim(msg)
        return
      end if
      t = rec%x(1, :)
      u = rec%x(2:, :)
      return
    end if
    nt = nint(c%t_end/c%dt) + 1
    t = [(real(k - 1, wp)*c%dt, k=1, nt)]
    allocate (u(c%nu, nt))
    u = 0.0_wp
    call deck_multisines(c, u, status, msg)
    if (status /= MLID_OK) return
    do k = 1, c%nu
      select case (trim(to_lower(c%input_shape(k))))
      case ('multisine')     ! made above, as one set; scaling keeps them orthogonal
        call finish_signal(u(k, :), .false., c%limit(k), status, msg)
        if (status /= MLID_OK) return
        cycle
      case ('sweep')
        call sweep('linear', c%f_band(1), c%f_band(2), c%amplitude(k), c%amplitude_end(k), &
                   c%pulse_width(k), c%dt, u(k, :), status, msg)
      case ('log_sweep')
        call sweep('log', c%f_band(1), c%f_band(2), c%amplitude(k), c%amplitude_end(k), &
                   c%pulse_width(k), c%dt, u(k, :), status, msg)
      case ('prbs')
        call prbs(c%prbs_order, nint(c%pulse_width(k)/c%dt), c%amplitude(k), u(k, :), status, msg)
      case default
        call input_signal(c%input_shape(k), c%amplitude(k), c%t_start(k), c%pulse_width(k), c%dt, &
                          u(k, :), status, msg)
        if (index(msg, 'unknown input shape') > 0) msg = trim(msg)//', '//SIGNAL_SHAPES
      end select
      if (status /= MLID_OK) return
      call finish_signal(u(k, :), c%zero_mean, c%limit(k), status, msg)
      if (status /= MLID_OK) return
    end do
  end procedure case_time_input

  !> The inputs whose shape is 'multisine': one set, mutually orthogonal over
  !> the record (T = t_end, the last sample repeating the first), in the band
  !> f_band, each input's peak its amplitude, its spectrum power's (flat
  !> when not given).
  subroutine deck_multisines(c, u, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(inout) :: u(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, allocatable :: ms(:), kh(:), own(:)
    real(wp), allocatable :: um(:, :), ph(:), ampl(:), r0(:), r1(:)
    integer :: k, ierr, iterations
    status = MLID_OK
    msg = ''
    ms = pack([(k, k=1, c%nu)], to_lower(c%input_shape) == 'multisine')
    if (size(ms) == 0) return
    call multisine_band(c%f_band(1), c%f_band(2), c%dt, size(u, 2) - 1, size(ms), kh, own, status, msg)
    if (status /= MLID_OK) return
    allocate (um(size(u, 2), size(ms)), ph(size(kh)), ampl(size(kh)), r0(size(ms)), r1(size(ms)), &
              stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'multisine: out of memory'
      return
    end if
    if (size(c%power) > 0 .and. size(c%power) /= size(kh)) then
      status = MLID_ERR_INPUT
      msg = 'multisine: power has '//itoa(size(c%power))//' values, the band holds '// &
            itoa(size(kh))//' harmonics (one per harmonic, all inputs'' in frequency order)'
      return
    end if
    iterations = merge(0, MULTISINE_ITERATIONS, c%phases == 'schroeder')
    if (size(c%power) == 0) then
      call multisine(kh, own, spread(1.0_wp, 1, size(kh)), c%amplitude(ms), iterations, &
                     um, ph, ampl, r0, r1, status, msg)
    else
      call multisine(kh, own, c%power, c%amplitude(ms), iterations, um, ph, ampl, r0, r1, &
                     status, msg)
    end if
    if (status == MLID_OK) u(ms, :) = transpose(um)
  end subroutine deck_multisines

end submodule mlid_deck_record
