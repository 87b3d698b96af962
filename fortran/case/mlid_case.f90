!> The case spec: everything one case of a deck (or a Python call) asks the
!> core to do: model kind and sizes, constants, the parameter vector with
!> free flags, ties and labels, options, prior and bounds, data files and
!> channels, the simulate job's inputs.  The deck reader fills it
!> (mlid_deck); case_values gives it by name (Python reads it so), so no
!> front end re-derives a layout.
module mlid_case
  use mlid_kinds, only: wp, msg_len, MLID_OK
  use mlid_model_factory, only: MODEL_LINEAR
  use mlid_options, only: NOPT, options_text
  use mlid_channels, only: channels_t
  use mlid_params, only: tie_t
  use mlid_named, only: named_t
  use mlid_text, only: join_lines
  use mlid_files, only: same_file
  use mlid_input_ranking, only: ranking_options_t
  use mlid_stepwise_text, only: CANDLEN
  use mlid_structure, only: uses_f_in, uses_f_out
  implicit none
  private
  public :: case_t, stepwise_spec_t, case_values, TITLE_CHARS, case_uses, NAMELEN, PATHLEN, MAXSEG, MAX_SAMPLES, NCONDITION, &
            CONDITION_NAMES, ONLINE_ESTIMATORS, ONLINE_TAKES

  integer, parameter :: NAMELEN = 32, PATHLEN = 512
  integer, parameter :: MAXSEG = 20     !< manoeuvres (data files) per case
  !> Samples of a simulated record at the most: checked before anything is
  !> allocated (a real manoeuvre has thousands).
  integer, parameter :: MAX_SAMPLES = 10000000
  !> &online's estimators: Fourier-transform regression, the augmented-state
  !> extended and unscented Kalman filters (the unscented in its standard
  !> and its augmented-noise form), the extended filter as forgetting-factor
  !> least squares, recursive least squares of the model's outputs on their
  !> free parameters
  character(len=16), parameter :: ONLINE_ESTIMATORS(6) = [character(len=16) :: 'ftr', 'ekf', &
                                                          'ukf', 'ukf_augmented', 'efrls', 'rls']
  !> The &online settings each estimator takes (beside estimator, out and
  !> timing), in ONLINE_ESTIMATORS' order: the deck refuses the others.
  character(len=64), parameter :: ONLINE_TAKES(6) = [character(len=64) :: &
    'f_min f_max n_freq every trim first forgetting', 'p0 q delta r_fade', 'p0 q r_fade', &
    'p0 q r_fade', 'p0 q delta forgetting', 'p0 p_max forgetting']

  !> The numeric flight-condition items of &case, in order.
  !> A title's characters at the most (UTF-8: up to four bytes each).
  integer, parameter :: TITLE_CHARS = 128
  integer, parameter :: NCONDITION = 3
  character(len=10), parameter :: CONDITION_NAMES(NCONDITION) = &
    [character(len=10) :: 'mach', 'altitude', 'alpha_trim']

  !> &stepwise (job 'stepwise', mlid_job_stepwise): the method ('forward',
  !> 'backward', 'mof'), the partial-F thresholds, sig2_max of PSE (0: the
  !> variance of y), the candidates from &data's inputs (products to
  !> degree, spline terms (v - knot)+^spline_degree of the variables
  !> knot_var), the constant, the terms always in, each output's &model
  !> item name for the model start ('' : its channel's name in lower case).
  type :: stepwise_spec_t
    character(len=16) :: method = 'forward'
    real(wp) :: f_in = 4.0_wp, f_out = 4.0_wp, sig2_max = 0.0_wp
    integer :: degree = 1, spline_degree = 1
    logical :: intercept = .true.
    integer, allocatable :: knot_var(:)
    real(wp), allocatable :: knots(:)
    character(len=CANDLEN), allocatable :: forced(:)
    character(len=NAMELEN), allocatable :: coefficients(:)
  contains
    procedure :: uses_f_in => stepwise_uses_f_in
    procedure :: uses_f_out => stepwise_uses_f_out
  end type stepwise_spec_t

  type :: case_t
    integer :: status = MLID_OK
    character(len=msg_len) :: msg = ''
    integer :: line = 0                       !< line of &case in the deck
    character(len=4*TITLE_CHARS) :: title = ''   !< TITLE_CHARS characters of UTF-8
    character(len=16) :: job = ''
    !> the flight condition (&case), for campaign tables: CONDITION_NAMES'
    !> values where given, the configuration and free-text tags
    real(wp) :: condition(NCONDITION) = 0.0_wp
    logical :: condition_given(NCONDITION) = .false.
    character(len=64) :: config = ''
    character(len=256) :: tags = ''
    integer :: mkind = MODEL_LINEAR
    integer, allocatable :: iconst(:)         !< model constants (longitudinal: regressor codes)
    real(wp), allocatable :: rconst(:)
    integer :: nx = 0, nu = 0, ny = 0, nw = 0
    real(wp), allocatable :: theta(:)         !< [F, G, H, D, Gamma, x0, bias, q, r, s]
    integer, allocatable :: isfree(:)
    type(tie_t) :: tie                        !< affine ties (mlid_params)
    integer :: use_prior = 0, use_bounds = 0
    real(wp), allocatable :: prior(:), pweight(:, :), lower(:), upper(:)  !< prior(nth) etc.
    character(len=NAMELEN), allocatable :: labels(:)  !< per free parameter, in the order of free
    character(len=NAMELEN), allocatable :: input_names(:), output_names(:)  !< channels, if named
    real(wp), allocatable :: initial_states(:)  !< nx per manoeuvre, if given (else x0 for each)
    !> &estimate x0_from ('' none, 'first', 'mean') and x0_samples: the
    !> measured states' x0 from each manoeuvre's record (mlid_initial_states)
    character(len=8) :: x0_from = ''
    integer :: x0_samples = 0
    integer :: iopt(NOPT) = 0
    real(wp) :: ropt(NOPT) = 0.0_wp
    !> the records, one per manoeuvre (relative paths are resolved from the deck)
    character(len=PATHLEN), allocatable :: data_files(:)
    integer, allocatable :: file_no(:)        !< each record's place in the deck's file list
    type(channels_t) :: chan                  !< the channels taken of each record
    real(wp), allocatable :: win_start(:), win_end(:)  !< time window of each record
    integer, allocatable :: holdout(:)                 !< validate: the files predicted
    character(len=PATHLEN) :: out_file = ''
    !> kind = 'flight_path': where each manoeuvre's record is written with
    !> the fit's corrections undone (&estimate corrected), if anywhere
    logical :: flight_path = .false.
    character(len=PATHLEN), allocatable :: corrected(:)
    real(wp) :: t_end = 0.0_wp, dt = 0.0_wp
    integer :: seed = 0
    real(wp), allocatable :: noise_std(:), amplitude(:)
    character(len=16), allocatable :: input_shape(:)   !< per input
    real(wp), allocatable :: t_start(:), pulse_width(:)  !< per input
    !> &simulate f_min, f_max: the band of its multisines and sweeps [Hz];
    !> prbs_order: its PRBS' register length
    real(wp) :: f_band(2) = 0.0_wp
    integer :: prbs_order = 0
    !> a sweep's amplitude at its end (per input; linear from amplitude),
    !> each input's limit on |u| (scaled down to it; 0: none), and whether
    !> every input is made to start and end at zero with zero mean
    real(wp), allocatable :: amplitude_end(:), limit(:)
    !> the multisines' relative power per harmonic of the band, all inputs'
    !> in frequency order (empty: flat)
    real(wp), allocatable :: power(:)
    !> the multisines' phases: 'optimised' (least relative peak factor) or
    !> 'schroeder' (Schroeder's, not iterated)
    character(len=16) :: phases = 'optimised'
    !> &online: the estimator, the band [Hz] and its frequencies, samples
    !> between solves, the trim's samples and the first sample transformed
    character(len=16) :: online_estimator = ''
    real(wp) :: online_band(2) = 0.0_wp
    integer :: online_nfreq = 0, online_every = 0, online_trim = 0, online_first = 1
    real(wp) :: online_lambda = 1.0_wp     !< the forgetting factor
    !> the filters' start variances and process-noise variances of the
    !> states then the free parameters, Jacobians' difference step (0:
    !> exact) and R's fading memory (0: R = &model's r)
    real(wp), allocatable :: online_p0(:), online_q(:)
    real(wp) :: online_delta = 0.0_wp, online_rfade = 0.0_wp
    !> rls: the bound on trace(P)/n of each regression (0: none)
    real(wp) :: online_pmax = 0.0_wp
    !> the estimator's time per sample in the report and JSON (asked for:
    !> a measured time makes two runs' bytes differ)
    logical :: online_timing = .false.
    logical :: zero_mean = .false.
    !> simulate and monte_carlo: a record whose time and first nu columns
    !> after it are the inputs (a designed input), instead of input_shape
    character(len=PATHLEN) :: input_file = ''
    !> design (&design; t_end is T, dt the record's step): the unknowns by
    !> block (1 F, 2 G, 3 H), row and column, and their labels
    integer, allocatable :: ukind(:), urow(:), ucol(:)
    character(len=NAMELEN), allocatable :: unknowns(:)
    real(wp), allocatable :: weights(:)       !< per unknown
    real(wp), allocatable :: servo(:)         !< servo time constant per input (0: none)
    real(wp), allocatable :: gq(:, :)         !< process noise Gamma Q Gamma' (nx, nx)
    real(wp), allocatable :: kx(:, :)         !< the state penalty K of report 7.6 (nx, nx; 0: none)
    character(len=16) :: design_method = ''
    real(wp) :: energy = 0.0_wp, peak = 0.0_wp, min_width = 0.0_wp
    integer :: iterations = 0                 !< equalised: weight updates tried
    !> design: the candidate inputs ranked beside the design (none: no ranking)
    type(ranking_options_t) :: ranking
    !> monte_carlo (&monte_carlo): runs (seed as simulate's), the true parameters
    integer :: runs = 0
    real(wp), allocatable :: theta_true(:)
    type(stepwise_spec_t) :: stepwise          !< &stepwise
  end type case_t

contains

  !> The thresholds the case's method uses (mlid_structure's).
  pure logical function stepwise_uses_f_in(s)
    class(stepwise_spec_t), intent(in) :: s
    stepwise_uses_f_in = uses_f_in(trim(s%method))
  end function stepwise_uses_f_in

  pure logical function stepwise_uses_f_out(s)
    class(stepwise_spec_t), intent(in) :: s
    stepwise_uses_f_out = uses_f_out(trim(s%method))
  end function stepwise_uses_f_out

  !> Whether case c reads or writes the file path: its data files, the
  !> inputs its Monte Carlo flies, the record it simulates or designs, its
  !> corrected records (same_file: links resolved).  A run's --json may be
  !> none of these.
  logical function case_uses(c, path)
    type(case_t), intent(in) :: c
    character(len=*), intent(in) :: path
    integer :: k
    case_uses = same_file(c%out_file, path) .or. same_file(c%input_file, path)
    if (allocated(c%data_files)) then
      do k = 1, size(c%data_files)
        case_uses = case_uses .or. same_file(c%data_files(k), path)
      end do
    end if
    if (allocated(c%corrected)) then
      do k = 1, size(c%corrected)
        case_uses = case_uses .or. same_file(c%corrected(k), path)
      end do
    end if
  end function case_uses

  !> Case c by name, as the front ends read it: where it is and what it
  !> does, its flight condition, and, when it can run, its model,
  !> parameters, options, prior, bounds, ties, files and channels (the
  !> defaults where the deck gives none: prior the start, no weight,
  !> unbounded).
  subroutine case_values(c, v)
    type(case_t), intent(in) :: c
    type(named_t), intent(out) :: v
    real(wp), allocatable :: zero(:, :)

    call v%put('line', c%line)
    call v%put('title', trim(c%title))
    call v%put('job', trim(c%job))
    call v%put('status', c%status)
    call v%put('message', trim(c%msg))
    call v%put('condition', c%condition)
    call v%put('condition_given', merge(1, 0, c%condition_given))
    call v%put('config', trim(c%config))
    call v%put('tags', trim(c%tags))
    if (c%status /= MLID_OK) return
    call v%put('mkind', c%mkind)
    call v%put('sizes', [c%nx, c%nu, c%ny, c%nw])
    call v%put('iconst', c%iconst)
    call v%put('rconst', c%rconst)
    call v%put('theta', c%theta)
    call v%put('isfree', c%isfree)
    call v%put('iopt', c%iopt)
    call v%put('ropt', c%ropt)
    call v%put('options', options_text(c%iopt, c%ropt))
    call v%put('labels', join_lines(c%labels))
    call v%put('tie_to', c%tie%to)
    call v%put('tie_from', c%tie%from)
    call v%put('tie_scale', c%tie%scale)
    call v%put('tie_offset', c%tie%offset)
    call v%put('use_prior', c%use_prior)
    if (allocated(c%prior)) then
      call v%put('prior', c%prior)
    else
      call v%put('prior', c%theta)
    end if
    if (allocated(c%pweight)) then
      call v%put('pweight', c%pweight)
    else
      allocate (zero(count(c%isfree > 0), count(c%isfree > 0)))
      zero = 0.0_wp
      call v%put('pweight', zero)
    end if
    call v%put('use_bounds', c%use_bounds)
    if (allocated(c%lower)) then
      call v%put('lower', c%lower)
    else
      call v%put('lower', spread(-huge(1.0_wp), 1, size(c%theta)))
    end if
    if (allocated(c%upper)) then
      call v%put('upper', c%upper)
    else
      call v%put('upper', spread(huge(1.0_wp), 1, size(c%theta)))
    end if
    if (allocated(c%input_names)) call v%put('input_names', join_lines(c%input_names))
    if (allocated(c%output_names)) call v%put('output_names', join_lines(c%output_names))
    if (allocated(c%data_files)) call v%put('data_files', join_lines(c%data_files))
    if (allocated(c%holdout)) call v%put('holdout', c%holdout)
    if (allocated(c%corrected)) call v%put('corrected', join_lines(c%corrected))
    if (allocated(c%initial_states)) call v%put('initial_states', c%initial_states)
    if (len_trim(c%x0_from) > 0) then
      call v%put('x0_from', trim(c%x0_from))
      call v%put('x0_samples', c%x0_samples)
    end if
  end subroutine case_values

end module mlid_case
