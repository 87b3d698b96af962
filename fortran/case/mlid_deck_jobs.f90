!> The readers of the groups of the jobs other than estimate and validate
!> (mlid_deck): &simulate (the record to write, its time base, inputs and
!> noise), &design (the input design's unknowns, record, limit, weights,
!> servo time constants, process noise and method) and &monte_carlo
!> (runs, seed, the input flown, the true values).
submodule (mlid_deck) mlid_deck_jobs
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan, ieee_value, ieee_quiet_nan
  use mlid_case, only: MAX_SAMPLES, ONLINE_ESTIMATORS, ONLINE_TAKES
  use mlid_model_factory, only: MODEL_LINEAR
  use mlid_layout, only: layout_table_t, layout_of, element_name
  use mlid_design_unknowns, only: unknown_entries, unknown_blocks
  use mlid_params, only: free_indices
  use mlid_input_ranking, only: ranking_options_t, check_ranking_options
  implicit none

  character(len=*), parameter :: FORGETTING_RANGE = &
    'group &online: forgetting (lambda) must be in (0, 1], 1 for none'

  !> The methods of &design.
  character(len=10), parameter :: DESIGN_METHODS(4) = [character(len=10) :: 'operator', &
                                                       'riccati', 'amplitude', 'equalised']

contains

  !> &simulate: the record to write, its time base, inputs and noise.
  module procedure read_simulate_group
    character(len=PATHLEN) :: out
    character(len=16) :: input_shape(MAXU), phases
    real(wp) :: t_end, dt, noise_std(MAXY), amplitude(MAXU), t_start(MAXU), pulse_width(MAXU)
    real(wp) :: f_min, f_max, amplitude_end(MAXU), limit(MAXU)
    real(wp), allocatable :: power(:)
    integer :: seed, ios, o, prbs_order
    logical :: zero_mean
    type(layout_table_t) :: lt
    character(len=msg_len) :: iomsg
    character(len=PATHLEN) :: input_file
    character(len=:), allocatable :: gtext
    namelist /simulate/ out, t_end, dt, seed, noise_std, input_shape, amplitude, t_start, &
      pulse_width, input_file, f_min, f_max, prbs_order, amplitude_end, limit, zero_mean, power, &
      phases

    out = ''
    f_min = 0.0_wp
    f_max = 0.0_wp
    prbs_order = 0
    amplitude_end = ieee_value(1.0_wp, ieee_quiet_nan)    ! not given
    limit = 0.0_wp
    zero_mean = .false.
    phases = 'optimised'
    allocate (power(MAX_HARMONICS), stat=ios)
    if (ios /= 0) then
      call fail(c, 'group &simulate: out of memory')
      return
    end if
    power = 1.0_wp
    t_end = 0.0_wp
    dt = 0.0_wp
    seed = 0
    noise_std = 0.0_wp          ! what a null value keeps (none for noise_std)
    input_shape = ''
    amplitude = 0.0_wp
    t_start = 0.0_wp
    pulse_width = 0.0_wp
    input_file = ''
    call at_most(rd, c, 'simulate', ['power'], MAX_HARMONICS, 'relative powers (one per harmonic)')
    if (c%status /= MLID_OK) return
    gtext = group_text(rd, 'simulate')
    ios = -1                          ! missing
    if (len(gtext) > 0) read (gtext, nml=simulate, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'simulate', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    if (too_long(rd, c, 'simulate', ['input_shape'], len(input_shape))) return
    if (too_long(rd, c, 'simulate', ['phases'], len(phases))) return
    c%out_file = out
    c%input_file = input_file
    c%t_end = t_end
    c%dt = dt
    c%seed = seed
    c%f_band = [f_min, f_max]
    c%prbs_order = prbs_order
    c%zero_mean = zero_mean
    c%phases = to_lower(phases)
    call take_list(rd, c, 'simulate', 'noise_std', noise_std, c%noise_std, .false.)
    call take_list(rd, c, 'simulate', 'amplitude', amplitude, c%amplitude, .true., c%nu)
    call take_list(rd, c, 'simulate', 't_start', t_start, c%t_start, .true., c%nu)
    call take_list(rd, c, 'simulate', 'pulse_width', pulse_width, c%pulse_width, .true., c%nu)
    call take_list(rd, c, 'simulate', 'amplitude_end', amplitude_end, c%amplitude_end, .true., c%nu)
    call take_list(rd, c, 'simulate', 'limit', limit, c%limit, .true., c%nu)
    call take_list(rd, c, 'simulate', 'power', power, c%power, .true.)
    if (c%status /= MLID_OK) return
    if (len_trim(input_file) > 0 .and. (t_end /= 0.0_wp .or. dt /= 0.0_wp .or. &
        any(len_trim(input_shape) > 0) .or. size(c%amplitude) > 0 .or. &
        size(c%t_start) > 0 .or. size(c%pulse_width) > 0 .or. any(c%f_band /= 0.0_wp) .or. &
        prbs_order /= 0 .or. size(c%amplitude_end) > 0 .or. size(c%limit) > 0 .or. zero_mean &
        .or. size(c%power) > 0 .or. c%phases /= 'optimised')) then
      call fail(c, 'group &simulate: input_file gives the time and inputs; t_end, dt, '// &
                'input_shape, amplitude, amplitude_end, t_start, pulse_width, f_min, f_max, '// &
                'prbs_order, limit, zero_mean, power and phases are for a standard input')
      return
    end if
    ! one value serves every input; otherwise one per input
    c%input_shape = per_input_text(input_shape, c%nu, 'none')
    c%t_start = per_input(c%t_start, c%nu)
    c%pulse_width = per_input(c%pulse_width, c%nu)
    if (size(c%amplitude) == 0) c%amplitude = spread(0.0_wp, 1, c%nu)
    c%limit = per_input(c%limit, c%nu)
    call shape_settings_used(c, size(c%amplitude_end) > 0)
    if (c%status /= MLID_OK) return
    if (size(c%amplitude_end) == 0) c%amplitude_end = [ieee_value(1.0_wp, ieee_quiet_nan)]
    c%amplitude_end = per_input(c%amplitude_end, c%nu)
    if (size(c%amplitude_end) == c%nu .and. size(c%amplitude) == c%nu) &   ! not given: the amplitude's
      c%amplitude_end = merge(c%amplitude, c%amplitude_end, ieee_is_nan(c%amplitude_end))
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
  end procedure read_simulate_group

  !> The settings of one kind of signal refused where no input has that
  !> shape (they would be read and ignored).
  subroutine shape_settings_used(c, shaped)
    type(case_t), intent(inout) :: c
    logical, intent(in) :: shaped
    logical :: sweeps, multisines
    sweeps = any(c%input_shape == 'sweep' .or. c%input_shape == 'log_sweep')
    multisines = any(c%input_shape == 'multisine')
    if (shaped .and. .not. sweeps) then
      call fail(c, 'group &simulate: amplitude_end is for sweeps (input_shape ''sweep'' or '// &
                '''log_sweep''), and no input is one')
    else if ((size(c%power) > 0 .or. c%phases /= 'optimised') .and. .not. multisines) then
      call fail(c, 'group &simulate: power and phases are for multisines (input_shape '// &
                '''multisine''), and no input is one')
    end if
  end subroutine shape_settings_used

  subroutine check_simulate(c)
    type(case_t), intent(inout) :: c
    character(len=msg_len) :: iomsg
    if (len_trim(c%out_file) == 0) then
      call fail(c, 'group &simulate: out (the data file to write) is missing')
    else if (len_trim(c%input_file) == 0 .and. .not. (c%dt > 0.0_wp .and. c%t_end > c%dt)) then
      call fail(c, 'group &simulate: need dt > 0 and t_end > dt')
    else if (len_trim(c%input_file) == 0 .and. .not. (c%t_end/c%dt < real(MAX_SAMPLES, wp))) then
      call fail(c, 'group &simulate: t_end/dt ='//es_text(c%t_end/c%dt, 10, 3)// &
                ' samples; at most '//itoa(MAX_SAMPLES)//' are allowed')
    else if (size(c%noise_std) /= c%ny .and. size(c%noise_std) /= 0) then
      write (iomsg, '(a,i0,a,i0,a)') 'group &simulate: noise_std has ', size(c%noise_std), &
        ' values, the model has ', c%ny, ' outputs'
      call fail(c, iomsg)
    else if (.not. all(c%noise_std >= 0.0_wp .and. ieee_is_finite(c%noise_std))) then
      call fail(c, 'group &simulate: noise_std (the standard deviation of each output''s '// &
                'noise) must be >= 0 and finite')
    else if (any(c%noise_std > sqrt(huge(1.0_wp)))) then
      call fail(c, 'group &simulate: noise_std('//itoa(findloc(c%noise_std > sqrt(huge(1.0_wp)), &
                .true., 1))//') is too large: its square, the variance r, is beyond the '// &
                'largest number ('//trim(es_text(sqrt(huge(1.0_wp)), 10, 3))//' at most)')
    else if (size(c%amplitude) /= c%nu) then
      write (iomsg, '(a,i0,a,i0,a)') 'group &simulate: amplitude has ', size(c%amplitude), &
        ' values, the model has ', c%nu, ' inputs'
      call fail(c, iomsg)
    else if (c%seed < 0) then
      call fail(c, 'group &simulate: seed must be >= 0')
    else if (size(c%input_shape) /= c%nu .or. size(c%t_start) /= c%nu .or. &
             size(c%pulse_width) /= c%nu .or. size(c%limit) /= c%nu .or. &
             size(c%amplitude_end) /= c%nu) then
      write (iomsg, '(a,i0,a)') 'group &simulate: input_shape, t_start, pulse_width, '// &
        'amplitude_end and limit take one value or one per input (', c%nu, ')'
      call fail(c, iomsg)
    else if (.not. all(c%limit >= 0.0_wp .and. ieee_is_finite(c%limit))) then
      call fail(c, 'group &simulate: limit (the largest |u| of each input; 0: none) must be '// &
                '>= 0 and finite')
    else if (c%phases /= 'optimised' .and. c%phases /= 'schroeder') then
      call fail(c, 'group &simulate: phases must be ''optimised'' (least relative peak '// &
                'factor) or ''schroeder'', not '''//trim(c%phases)//'''')
    else if (.not. all(c%power >= 0.0_wp .and. ieee_is_finite(c%power))) then
      call fail(c, 'group &simulate: power (the multisines'' relative power per harmonic) '// &
                'must be >= 0 and finite')
    else if (.not. all(ieee_is_finite(c%amplitude_end))) then
      call fail(c, 'group &simulate: amplitude_end (a sweep''s amplitude at its end) must be '// &
                'finite')
    end if
  end subroutine check_simulate

  !> The values given (v), or the one value repeated for every input
  !> (zeros when none is given).
  function per_input(v, n) result(out)
    real(wp), intent(in) :: v(:)
    integer, intent(in) :: n
    real(wp), allocatable :: out(:)
    out = v
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
  module procedure read_design_group
    character(len=NAMELEN) :: unknowns(MAXFREE)
    character(len=16) :: method
    character(len=PATHLEN) :: out
    real(wp) :: t_end, dt, energy, peak, min_width, weights(MAXFREE), servo(MAXU), &
                process_noise(MAXX*MAXX), state_penalty(MAXX*MAXX)
    integer :: iterations, ios, nunk
    character(len=msg_len) :: iomsg
    real(wp), allocatable :: wts(:), srv(:), pn(:), kx(:)
    character(len=:), allocatable :: gtext
    character(len=16) :: candidates(16), compare, rank_by
    real(wp) :: f_min, f_max, pulse_width
    namelist /design/ unknowns, t_end, dt, energy, peak, min_width, weights, servo, &
      process_noise, method, iterations, out, state_penalty, candidates, compare, rank_by, &
      f_min, f_max, pulse_width

    unknowns = ''
    method = ''
    out = ''
    t_end = 0.0_wp
    dt = 0.0_wp
    energy = 0.0_wp              ! what an entry not given (or a null) keeps
    peak = 0.0_wp
    min_width = 0.0_wp
    weights = 1.0_wp
    servo = 0.0_wp
    process_noise = 0.0_wp
    state_penalty = 0.0_wp
    iterations = 12
    candidates = ''
    compare = 'energy'
    rank_by = 'det'
    f_min = 0.0_wp
    f_max = 0.0_wp
    pulse_width = 0.0_wp
    call at_most(rd, c, 'design', ['unknowns', 'weights '], MAXFREE, 'unknowns')
    if (c%status == MLID_OK) call at_most(rd, c, 'design', ['candidates'], size(candidates), &
                                          'candidates')
    if (c%status /= MLID_OK) return
    gtext = group_text(rd, 'design')
    ios = -1                          ! missing
    if (len(gtext) > 0) read (gtext, nml=design, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'design', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    if (too_long(rd, c, 'design', ['method'], len(method))) return
    if (too_long(rd, c, 'design', ['unknowns'], len(unknowns))) return
    if (too_long(rd, c, 'design', ['candidates', 'compare   ', 'rank_by   '], len(compare))) return
    c%ranking = ranking_options_t(pack(candidates, len_trim(candidates) > 0), compare, rank_by, &
                                  f_min, f_max, pulse_width)
    c%out_file = out
    c%t_end = t_end
    c%dt = dt
    c%design_method = to_lower(method)
    c%energy = energy
    c%peak = peak
    c%min_width = min_width
    c%iterations = iterations
    if (len_trim(method) == 0) c%design_method = merge('amplitude', 'operator ', &
                                                        is_given(rd, 'design', 'peak'))
    ! unknowns has no default but the free parameters: a null would drop one unseen
    call list_length(rd, c, 'design', 'unknowns', size(unknowns), .false., nunk)
    if (c%status == MLID_OK) call design_model_check(c)
    if (c%status == MLID_OK) call design_unknowns(c, unknowns)
    if (c%status /= MLID_OK) return
    call take_list(rd, c, 'design', 'weights', weights, wts, .true., size(c%ukind))
    call take_list(rd, c, 'design', 'servo', servo, srv, .true., c%nu)
    call take_list(rd, c, 'design', 'process_noise', process_noise, pn, .false.)
    call take_list(rd, c, 'design', 'state_penalty', state_penalty, kx, .false.)
    if (c%status == MLID_OK) call design_settings(c, wts, srv, pn)
    if (c%status == MLID_OK) call design_limits(c, is_given(rd, 'design', 'energy'), &
      is_given(rd, 'design', 'peak') .or. is_given(rd, 'design', 'min_width'))
    if (c%status == MLID_OK) call design_penalty(c, kx)
    if (c%status == MLID_OK) call design_ranking(rd, c)
  end procedure read_design_group

  !> The state penalty K of report 7.6 (tr(WM) - int x'Kx dt): one weight
  !> >= 0 per state (K diagonal) or nx x nx values row by row, symmetric
  !> (the core checks K >= 0 when it designs); none: K = 0.  The energy
  !> methods take it (the criterion stays a quadratic form in u).
  subroutine design_penalty(c, kx)
    type(case_t), intent(inout) :: c
    real(wp), intent(in) :: kx(:)
    integer :: k
    allocate (c%kx(c%nx, c%nx))
    c%kx = 0.0_wp
    if (size(kx) == c%nx) then
      do k = 1, c%nx
        c%kx(k, k) = kx(k)
      end do
    else if (size(kx) == c%nx*c%nx) then
      c%kx = transpose(reshape(kx, [c%nx, c%nx]))
    else if (size(kx) > 0) then
      call fail(c, 'group &design: state_penalty takes one weight per state ('//itoa(c%nx)// &
                ') or nx x nx = '//itoa(c%nx*c%nx)//' values row by row, got '//itoa(size(kx)))
      return
    end if
    if (.not. all(ieee_is_finite(c%kx))) then
      call fail(c, 'group &design: state_penalty must be finite')
    else if (any(abs(c%kx - transpose(c%kx)) > 1.0e-12_wp*maxval(abs(c%kx)))) then
      call fail(c, 'group &design: state_penalty (K) must be symmetric')
    else if (any([(c%kx(k, k), k=1, c%nx)] < 0.0_wp)) then
      call fail(c, 'group &design: state_penalty weights must be >= 0 (K >= 0)')
    else if (any(c%kx /= 0.0_wp) .and. all(c%design_method /= ['operator', 'riccati '])) then
      call fail(c, 'group &design: state_penalty is for method ''operator'' or ''riccati'', '// &
                'not '''//trim(c%design_method)//'''')
    end if
  end subroutine design_penalty

  !> The candidates ranked beside the design (mlid_input_ranking), checked
  !> as the ranking checks them, on the record's cells of dt.
  subroutine design_ranking(rd, c)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    integer :: ios, k
    character(len=msg_len) :: iomsg
    character(len=11), parameter :: SETTINGS(5) = [character(len=11) :: 'compare', 'rank_by', &
                                                   'f_min', 'f_max', 'pulse_width']
    if (size(c%ranking%names) == 0) then
      do k = 1, size(SETTINGS)
        if (.not. is_given(rd, 'design', trim(SETTINGS(k)))) cycle
        call fail(c, 'group &design: '//trim(SETTINGS(k))//' is for the ranking of '// &
                  'candidates: list them in candidates')
        return
      end do
    end if
    call check_ranking_options(c%ranking, 0.5_wp/c%dt, ios, iomsg)
    if (ios /= MLID_OK) call fail(c, 'group &design: '//trim(iomsg))
  end subroutine design_ranking

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
    integer :: k, ios
    character(len=msg_len) :: iomsg

    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, ios, iomsg)
    if (any(len_trim(unknowns) > 0)) then
      call unknown_entries(lt, unknowns, idx, ios, iomsg)
      if (ios /= MLID_OK) then
        call fail(c, 'group &design: '//trim(iomsg))
        return
      end if
    else
      idx = free_indices(c%isfree)
    end if
    if (size(idx) == 0) then
      call fail(c, 'group &design: no unknowns: list them in &design unknowns or free them '// &
                'in &model')
      return
    end if
    call unknown_blocks(lt, idx, c%ukind, c%urow, c%ucol, ios, iomsg)
    if (ios /= MLID_OK) then
      call fail(c, 'group &design: '//trim(iomsg))
      return
    end if
    allocate (c%unknowns(size(idx)))
    do k = 1, size(idx)
      c%unknowns(k) = element_name(lt, idx(k))
      if (c%isfree(idx(k)) > 0) c%unknowns(k) = c%labels(findloc(free_indices(c%isfree), idx(k), 1))
    end do
  end subroutine design_unknowns

  !> Weights (one per unknown, > 0; default ones), servo time constants
  !> (one, or one per input; >= 0, 0 for none) and process noise (nx x nx,
  !> row by row, symmetric; default none), as the deck gave them.
  subroutine design_settings(c, weights, servo, process_noise)
    type(case_t), intent(inout) :: c
    real(wp), intent(in) :: weights(:), servo(:), process_noise(:)
    integer :: m

    m = size(c%ukind)
    c%weights = weights
    if (size(c%weights) == 0) c%weights = spread(1.0_wp, 1, m)
    c%servo = per_input(servo, c%nu)
    c%gq = transpose(reshape(process_noise, [c%nx, c%nx], &
                             pad=[0.0_wp]))
    if (size(c%weights) /= m .or. .not. all(c%weights > 0.0_wp .and. ieee_is_finite(c%weights))) then
      call fail(c, 'group &design: weights takes one value > 0 per unknown ('//itoa(m)//')')
    else if (size(c%servo) /= c%nu .or. .not. all(c%servo >= 0.0_wp .and. ieee_is_finite(c%servo))) then
      call fail(c, 'group &design: servo takes one time constant >= 0 (s; 0: none), or one '// &
                'per input ('//itoa(c%nu)//')')
    else if (all(size(process_noise) /= [0, c%nx*c%nx])) then
      call fail(c, 'group &design: process_noise is Gamma Q Gamma'' (nx x nx = '// &
                itoa(c%nx*c%nx)//' values, row by row), got '// &
                itoa(size(process_noise)))
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
    else if (.not. (c%dt > 0.0_wp .and. c%t_end > c%dt .and. ieee_is_finite(c%t_end))) then
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
  module procedure read_monte_carlo_group
    integer :: runs, seed, ios, nf
    real(wp) :: truth(MAXFREE)
    real(wp), allocatable :: tr(:)
    character(len=PATHLEN) :: input_file
    character(len=msg_len) :: iomsg
    character(len=:), allocatable :: gtext
    namelist /monte_carlo/ runs, seed, truth, input_file

    runs = 0
    seed = 1
    truth = 0.0_wp                ! a null keeps the start value
    truth(1:size(free_idx)) = c%theta(free_idx)
    input_file = ''
    call at_most(rd, c, 'monte_carlo', ['truth'], MAXFREE, 'free parameters')
    if (c%status /= MLID_OK) return
    gtext = group_text(rd, 'monte_carlo')
    ios = -1                          ! missing
    if (len(gtext) > 0) read (gtext, nml=monte_carlo, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'monte_carlo', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    nf = size(free_idx)
    c%runs = runs
    c%seed = seed
    c%input_file = input_file
    c%theta_true = c%theta
    call take_list(rd, c, 'monte_carlo', 'truth', truth, tr, .true., nf)
    if (c%status /= MLID_OK) return
    if (size(tr) == nf .and. nf > 0) c%theta_true(free_idx) = tr
    if (len_trim(input_file) == 0) then
      call fail(c, 'group &monte_carlo: input_file (the record of the input flown) is missing')
    else if (runs < 1 .or. runs > 1000000) then
      call fail(c, 'group &monte_carlo: runs must be 1 to 1000000, got '//itoa(runs))
    else if (seed < 0 .or. seed > huge(1) - runs) then
      call fail(c, 'group &monte_carlo: seed must be >= 0 (runs use seed, seed + 1, ...)')
    else if (nf == 0) then
      call fail(c, 'group &monte_carlo: nothing is free in &model: there is nothing to estimate')
    else if (all(size(tr) /= [0, nf])) then
      call fail(c, 'group &monte_carlo: truth takes one value per free parameter ('// &
                itoa(nf)//', in the order of free), got '//itoa(size(tr)))
    else if (.not. all(ieee_is_finite(c%theta_true))) then
      call fail(c, 'group &monte_carlo: truth must be finite')
    end if
  end procedure read_monte_carlo_group

  !> &online (job 'online'): the estimator ('ftr': Fourier-transform
  !> regression, mlid_ftr), its band (f_min, f_max [Hz], n_freq frequencies
  !> evenly spaced, the ends included), samples between solves, the trim's
  !> samples, the first sample transformed, and the record of the history.
  module procedure read_online_group
    character(len=16) :: estimator
    character(len=PATHLEN) :: out
    real(wp) :: f_min, f_max, forgetting, p0(MAXX + MAXFREE), q(MAXX + MAXFREE), delta, r_fade
    real(wp) :: p_max
    integer :: n_freq, every, trim, first, ios
    logical :: timing
    character(len=msg_len) :: iomsg
    character(len=:), allocatable :: gtext
    namelist /online/ estimator, f_min, f_max, n_freq, every, trim, first, forgetting, p0, q, &
      delta, r_fade, out, p_max, timing

    estimator = 'ftr'
    f_min = 0.0_wp
    f_max = 0.0_wp
    n_freq = 0
    every = 0
    trim = 10
    first = 1
    forgetting = 1.0_wp
    p0 = 0.0_wp
    q = 0.0_wp
    delta = 0.0_wp
    r_fade = 0.0_wp
    p_max = 0.0_wp
    timing = .false.
    out = ''
    call at_most(rd, c, 'online', ['p0', 'q '], MAXX + MAXFREE, 'states and free parameters')
    if (c%status /= MLID_OK) return
    gtext = group_text(rd, 'online')
    ios = -1                          ! missing
    if (len(gtext) > 0) read (gtext, nml=online, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'online', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    if (too_long(rd, c, 'online', ['estimator'], len(estimator))) return
    c%online_estimator = to_lower(estimator)
    c%online_band = [f_min, f_max]
    c%online_nfreq = n_freq
    c%online_every = every
    c%online_trim = trim
    c%online_first = first
    c%online_lambda = forgetting
    c%online_delta = delta
    c%online_rfade = r_fade
    c%online_pmax = p_max
    c%online_timing = timing
    call take_list(rd, c, 'online', 'p0', p0, c%online_p0, .false.)
    call take_list(rd, c, 'online', 'q', q, c%online_q, .false.)
    if (c%status /= MLID_OK) return
    c%out_file = out
    call refuse_untaken(rd, c)
    if (c%status == MLID_OK .and. c%online_estimator == 'rls') call check_online_rls(rd, c, free_idx)
    if (c%status /= MLID_OK) return
    call check_online(c, free_idx)
  end procedure read_online_group

  !> A setting of &online that the estimator does not take (ONLINE_TAKES)
  !> fails the case: it would be ignored.  An unknown estimator is
  !> check_online's to name.
  subroutine refuse_untaken(rd, c)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    character(len=:), allocatable :: all, takes
    integer :: e, i, j
    e = findloc(ONLINE_ESTIMATORS, c%online_estimator, 1)
    if (e == 0) return
    all = ' '//trim(joined_words(ONLINE_TAKES))//' '
    takes = ' '//trim(ONLINE_TAKES(e))//' '
    i = 1
    do while (i < len(all))
      j = index(all(i + 1:), ' ') + i
      if (j > i + 1) then
        if (is_given(rd, 'online', all(i + 1:j - 1)) .and. index(takes, all(i:j)) == 0) then
          call fail(c, 'group &online: '''//trim(c%online_estimator)//''' does not take '// &
                    all(i + 1:j - 1)//' (it takes '//trim(ONLINE_TAKES(e))//')')
          return
        end if
      end if
      i = j
    end do
  contains
    function joined_words(list) result(text)
      character(len=*), intent(in) :: list(:)
      character(len=:), allocatable :: text
      integer :: k
      text = ''
      do k = 1, size(list)
        text = text//' '//trim(list(k))
      end do
    end function joined_words
  end subroutine refuse_untaken

  !> Recursive least squares (mlid_job_rls): a model of no states whose
  !> outputs take the free parameters (the model's own), one P0 for all
  !> regressions or one per output, no process noise, a bound >= 0.
  subroutine check_online_rls(rd, c, free_idx)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    integer, intent(in) :: free_idx(:)
    type(layout_table_t) :: lt
    integer :: ios
    character(len=msg_len) :: iomsg
    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, ios, iomsg)
    if (ios /= MLID_OK) then
      call fail(c, 'group &online: '//trim(iomsg))
    else if (c%nx /= 0) then
      call fail(c, 'group &online: ''rls'' regresses the outputs of a model with no states '// &
                '(nx = 0, e.g. kind = ''equations''), not nx = '//itoa(c%nx))
    else if (size(free_idx) == 0 .or. any(free_idx > lt%np)) then
      call fail(c, 'group &online: ''rls'' estimates the model''s own parameters: free must '// &
                'list some, and no bias or noise entry')
    else if (all(size(c%online_p0) /= [0, 1, c%ny])) then
      call fail(c, 'group &online: ''rls'' takes one p0 (P0 = p0 I) for all outputs or one '// &
                'per output ('//itoa(c%ny)//'), got '//itoa(size(c%online_p0)))
    else if (.not. all(c%online_p0 > 0.0_wp .and. ieee_is_finite(c%online_p0))) then
      call fail(c, 'group &online: p0 must be > 0 and finite')
    else if (tied(c)) then
      call fail(c, 'group &online: ''rls'' does not follow ties (a tied parameter would stay '// &
                'at its start): give the model without them')
    else if (.not. (c%online_pmax >= 0.0_wp .and. ieee_is_finite(c%online_pmax))) then
      call fail(c, 'group &online: p_max (the bound on trace(P)/n) must be >= 0 (0: none) '// &
                'and finite')
    else if (.not. (c%online_lambda > 0.0_wp .and. c%online_lambda <= 1.0_wp)) then
      call fail(c, FORGETTING_RANGE)
    end if
  end subroutine check_online_rls

  !> What the online job takes: its estimator's names and settings, and a
  !> model it can estimate (ftr: linear, the states measured, H = I and D
  !> zero, every entry of F and G free and nothing else).
  subroutine check_online(c, free_idx)
    type(case_t), intent(inout) :: c
    integer, intent(in) :: free_idx(:)
    type(layout_table_t) :: lt
    integer :: ios, fb, gb, hb, db, k
    integer, allocatable :: want(:)
    character(len=msg_len) :: iomsg
    if (all(ONLINE_ESTIMATORS /= c%online_estimator)) then
      call fail(c, 'group &online: estimator must be ''ftr'' (Fourier-transform regression), '// &
                '''ekf'', ''ukf'', ''ukf_augmented'' (the augmented-state filters), ''efrls'' '// &
                '(the extended filter as forgetting-factor least squares) or ''rls'' '// &
                '(recursive least squares), not '''// &
                trim(c%online_estimator)//'''')
      return
    else if (len_trim(c%out_file) == 0) then
      call fail(c, 'group &online: out (the record of the estimates'' history to write) is missing')
      return
    else if (c%online_estimator == 'rls') then
      return
    else if (c%online_estimator /= 'ftr') then
      call check_online_filter(c, free_idx)
      return
    else if (.not. (c%online_band(1) > 0.0_wp .and. c%online_band(2) > c%online_band(1) .and. &
                    ieee_is_finite(c%online_band(2))) .or. c%online_nfreq < 2) then
      call fail(c, 'group &online: the band needs 0 < f_min < f_max (Hz) and n_freq >= 2 '// &
                'frequencies')
      return
    else if (.not. (c%online_lambda > 0.0_wp .and. c%online_lambda <= 1.0_wp)) then
      call fail(c, FORGETTING_RANGE)
      return
    else if (c%online_every < 1 .or. c%online_trim < 0 .or. c%online_first < 1) then
      call fail(c, 'group &online: every (samples between solves) must be >= 1, trim >= 0 and '// &
                'first >= 1')
      return
    end if
    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, ios, iomsg)
    if (ios /= MLID_OK .or. c%mkind /= MODEL_LINEAR .or. c%nu < 1 .or. c%ny /= c%nx) then
      call fail(c, 'group &online: ''ftr'' needs kind = ''linear'' with inputs and every state '// &
                'measured (ny = nx, H = I, D = 0)')
      return
    end if
    fb = findloc(lt%key, 'f', 1)
    gb = findloc(lt%key, 'g', 1)
    want = [(lt%off(fb) + k, k=1, c%nx*c%nx), (lt%off(gb) + k, k=1, c%nx*c%nu)]
    hb = lt%off(findloc(lt%key, 'h', 1))
    db = lt%off(findloc(lt%key, 'd', 1))
    if (any(c%theta(hb + 1:hb + c%nx*c%nx) /= reshape(identity(c%nx), [c%nx*c%nx])) .or. &
        any(c%theta(db + 1:db + c%nx*c%nu) /= 0.0_wp)) then
      call fail(c, 'group &online: ''ftr'' needs H = I and D = 0 (every state measured, in '// &
                'order)')
    else if (size(free_idx) /= size(want) .or. any(count_in(want, free_idx) /= 1)) then
      call fail(c, 'group &online: ''ftr'' estimates every entry of F and G: free must list '// &
                'them all ('//itoa(size(want))//') and nothing else')
    end if
  end subroutine check_online

  !> The augmented-state filters: the free parameters the model's own (not
  !> x0, biases or noise), p0 and q one per state and free parameter; the
  !> rest (values, r) the filter checks when it runs.
  subroutine check_online_filter(c, free_idx)
    type(case_t), intent(inout) :: c
    integer, intent(in) :: free_idx(:)
    type(layout_table_t) :: lt
    integer :: ios, n
    character(len=msg_len) :: iomsg
    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, ios, iomsg)
    n = c%nx + size(free_idx)
    if (ios /= MLID_OK) then
      call fail(c, 'group &online: '//trim(iomsg))
    else if (size(free_idx) == 0 .or. any(free_idx > lt%np)) then
      call fail(c, 'group &online: the filters estimate the model''s own parameters: free must '// &
                'list some, and no x0, bias or noise entry')
    else if (tied(c)) then
      call fail(c, 'group &online: the online filters do not follow ties: give the model '// &
                'without them')
    else if (size(c%online_p0) /= n .or. size(c%online_q) /= n) then
      call fail(c, 'group &online: p0 and q take one variance per state and free parameter ('// &
                itoa(n)//', the states first)')
    else if (.not. (c%online_lambda > 0.0_wp .and. c%online_lambda <= 1.0_wp)) then
      call fail(c, FORGETTING_RANGE)
    end if
  end subroutine check_online_filter

  !> Whether case c ties parameters (the online estimators estimate the
  !> free ones alone).
  pure logical function tied(c)
    type(case_t), intent(in) :: c
    tied = .false.
    if (allocated(c%tie%to)) tied = size(c%tie%to) > 0
  end function tied

  pure function identity(n) result(a)
    integer, intent(in) :: n
    real(wp) :: a(n, n)
    integer :: i
    a = 0.0_wp
    do i = 1, n
      a(i, i) = 1.0_wp
    end do
  end function identity

  !> How often each of want is in have.
  pure function count_in(want, have) result(n)
    integer, intent(in) :: want(:), have(:)
    integer :: n(size(want)), k
    do k = 1, size(want)
      n(k) = count(have == want(k))
    end do
  end function count_in

end submodule mlid_deck_jobs
