!> The deck jobs that run whole in the core, for both front ends alike
!> (run_case, mlid_run, calls job_run for them, for both front ends):
!>   simulate     a record from the model, a standard input or input_file
!>   design       the optimal input of &design (report §7), written as a
!>                record of t and the inputs, its information summarised
!>   monte_carlo  seeded runs: simulate from the truth, fit from &model
!>   online       an online estimator's history (FTR, the filters here;
!>                recursive least squares in mlid_job_rls)
!>   stepwise     the model structure of each output (mlid_job_stepwise)
!> Each returns the report lines and the JSON object of the case (written
!> once, in mlid_job_report); files are written whole or not at all.
module mlid_jobs
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_finite
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_case, only: case_t, NAMELEN
  use mlid_deck, only: case_time_input, case_record
  use mlid_ftr, only: ftr_settings_t, ftr_run
  use mlid_frequency, only: freq_grid
  use mlid_online_filter, only: filter_settings_t
  use mlid_online_ekf, only: ekf_run
  use mlid_online_ukf, only: ukf_run
  use mlid_model_factory, only: model_create
  use mlid_online_history, only: convergence_times
  use mlid_job_rls, only: online_rls
  use mlid_job_stepwise, only: stepwise_job
  use mlid_layout, only: layout_table_t, layout_of
  use mlid_models, only: model_t, layout_t, model_layout
  use mlid_options, only: options_t
  use mlid_params, only: param_map_t, free_indices
  use mlid_setup, only: setup
  use mlid_simulate, only: simulate_flat
  use mlid_monte_carlo, only: monte_carlo, mc_statistics
  use mlid_record, only: record_text
  use mlid_units, only: UNITLEN
  use mlid_files, only: write_file
  use mlid_text, only: itoa, to_lower, es_text
  use mlid_memory, only: no_memory
  use mlid_input_ranking, only: rank_candidates
  use mlid_progress, only: progress_t
  use mlid_design, only: design_t, design_create, operator_mu, mu_for_length, transition_length, &
                         RICCATI_BRACKET, &
                         costate_input, input_information, amplitude_limited_input, &
                         operator_input, &
                         equalised_input, information_summary, servo_model, &
                         design_state_penalty, input_response, simpson_weights
  use mlid_signals, only: multisine_band, peak_factor
  use mlid_job_report, only: online_summary_t, online_report, online_json, input_summary_t, &
                             design_summary_t, design_report, design_json, mc_summary_t, &
                             mc_report, mc_json, simulate_report, simulate_json
  implicit none
  private
  public :: job_run, JOB_RUNS, around_t, hook_t

  !> Called before and after the numerical work of a case (a fit, the runs
  !> of a Monte Carlo), which builds no text: a front end lets its other
  !> threads run meanwhile (Python: the GIL released, python/mlid/_gil.c,
  !> and its progress bar read then); the batch program gives none.
  abstract interface
    subroutine hook_t() bind(c)
    end subroutine hook_t
  end interface
  type :: around_t
    procedure(hook_t), pointer, nopass :: begin => null(), end => null()
  end type around_t

  !> The jobs run here (the others are fits, run by the front ends)
  character(len=*), parameter :: JOB_RUNS = ' simulate design monte_carlo online stepwise '
  real(wp), parameter :: PI = 4.0_wp*atan(1.0_wp)
  character, parameter :: NL = achar(10)

contains

  !> Run case c's job; report and json are empty when it failed (status,
  !> msg say why).  around: the hooks around its long numerical work;
  !> progress: that work's count (mlid_progress).
  subroutine job_run(c, report, json, status, msg, around, progress)
    type(case_t), intent(in) :: c
    character(len=:), allocatable, intent(out) :: report, json
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(around_t), intent(in), optional :: around
    type(progress_t), intent(inout), optional :: progress

    report = ''
    json = ''
    status = c%status
    msg = c%msg
    if (status /= MLID_OK) return
    select case (c%job)
    case ('simulate')
      call simulate_job(c, report, json, status, msg)
    case ('design')
      call design_job(c, report, json, status, msg)
    case ('monte_carlo')
      call monte_carlo_job(c, report, json, status, msg, around, progress)
    case ('online')
      call online_job(c, report, json, status, msg)
    case ('stepwise')
      call stepwise_job(c, report, json, status, msg)
    case default
      status = MLID_ERR_INPUT
      msg = 'job '''//trim(c%job)//''' is a fit, not run by job_run'
    end select
    if (status /= MLID_OK) then
      report = ''
      json = ''
    end if
  end subroutine job_run

  !> simulate: the outputs with the seeded noise of r, written with t and
  !> the inputs to out.
  subroutine simulate_job(c, report, json, status, msg)
    type(case_t), intent(in) :: c
    character(len=:), allocatable, intent(inout) :: report, json
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: t(:), u(:, :), y(:, :), x(:, :)
    character(len=:), allocatable :: text
    character(len=NAMELEN), allocatable :: names(:)
    character(len=UNITLEN), allocatable :: units(:)
    type(input_summary_t), allocatable :: inputs(:)

    call case_time_input(c, t, u, status, msg)
    if (status == MLID_OK) call input_summaries(c, t, u, inputs, status, msg)
    if (status /= MLID_OK) return
    allocate (y(c%ny, size(t)), x(c%nx, size(t)))
    call simulate_flat(c%mkind, c%nx, c%nu, c%ny, c%nw, c%theta, c%iconst, c%rconst, t, u, c%iopt, &
                       c%ropt, c%seed, y, x, status, msg)
    if (status /= MLID_OK) return
    ! the header mlid has always written here; the rows are the reader's own
    allocate (names(c%nu + c%ny), units(c%nu + c%ny))
    names = ''
    units = ''
    call record_text(names, units, t, u, y, text, status, msg, &
                     first_line='# t, inputs, outputs (mlid simulate)')
    if (status /= MLID_OK) return
    call write_file(c%out_file, text, status, msg)
    if (status /= MLID_OK) return
    report = simulate_report(size(t), c%out_file, inputs)
    json = simulate_json(c%title, c%job, size(t), c%out_file, inputs)
  end subroutine simulate_job

  !> What the report says of each simulated input; a multisine's harmonics
  !> are asked again of multisine_band, which dealt them (the same call as
  !> case_time_input's), a sweep's band is f_band.
  subroutine input_summaries(c, t, u, inputs, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: t(:), u(:, :)
    type(input_summary_t), allocatable, intent(out) :: inputs(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, allocatable :: kh(:), own(:), ms(:)
    integer :: k
    status = MLID_OK
    msg = ''
    allocate (inputs(c%nu))
    ms = [integer ::]
    if (len_trim(c%input_file) == 0) then
      ms = pack([(k, k=1, c%nu)], to_lower(c%input_shape) == 'multisine')
      if (size(ms) > 0) call multisine_band(c%f_band(1), c%f_band(2), c%dt, size(t) - 1, &
                                            size(ms), kh, own, status, msg)
      if (status /= MLID_OK) return
    end if
    do k = 1, c%nu
      inputs(k)%name = input_name(c, k)
      inputs(k)%shape = 'file'
      if (len_trim(c%input_file) == 0) inputs(k)%shape = to_lower(c%input_shape(k))
      inputs(k)%peak = maxval(abs(u(k, :)))
      inputs(k)%rms = sqrt(sum(u(k, :)**2)/size(t))
      inputs(k)%rpf = peak_factor(u(k, :))
      select case (inputs(k)%shape)
      case ('multisine')
        inputs(k)%freq = pack(kh, own == findloc(ms, k, 1))/((size(t) - 1)*c%dt)
      case ('sweep', 'log_sweep')
        inputs(k)%freq = c%f_band
      case default
        allocate (inputs(k)%freq(0))
      end select
    end do
  end subroutine input_summaries

  !> design: the optimal input of &design on the model of &model (through
  !> its servo, if any), held over the record's steps and written to out.
  subroutine design_job(c, report, json, status, msg)
    type(case_t), intent(in) :: c
    character(len=:), allocatable, intent(inout) :: report, json
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(design_summary_t) :: s
    real(wp), allocatable :: f(:, :), g(:, :), h(:, :), r(:, :), gq(:, :), u(:), t(:), uc(:, :)
    integer :: ks(size(c%ukind)), cs(size(c%ukind)), n, k, m
    character(len=NAMELEN), allocatable :: names(:)
    character(len=UNITLEN), allocatable :: units(:)
    real(wp), allocatable :: none(:, :)
    character(len=:), allocatable :: text

    m = size(c%ukind)
    n = nint(c%t_end/c%dt)
    call design_matrices(c, f, g, h, r, gq, ks, cs, status, msg)
    if (status /= MLID_OK) return
    s%method = c%design_method
    s%weights = c%weights
    allocate (s%mm(m, m))
    call design_input(c, f, g, h, r, gq, ks, cs, n, s, u, status, msg)
    if (status /= MLID_OK) return
    ! the record: sample k holds the cell it starts, the last the one before
    s%cells = size(u)/c%nu
    t = [(c%t_end*(real(k, wp)/n), k=0, n)]
    allocate (uc(c%nu, n + 1))
    do k = 1, n
      uc(:, k) = u(((k - 1)*s%cells/n)*c%nu + 1:((k - 1)*s%cells/n + 1)*c%nu)
    end do
    uc(:, n + 1) = uc(:, n)
    s%energy = sum(u**2)*c%t_end/s%cells
    s%peak = maxval(abs(u))
    if (any(c%kx /= 0.0_wp)) call state_excursions(c, f, g, u, s, status, msg)
    if (status /= MLID_OK) return
    s%t = c%t_end
    s%labels = c%unknowns
    s%servo = c%servo
    s%noise = any(c%gq /= 0.0_wp)
    s%samples = n + 1
    s%out = c%out_file
    allocate (s%sigma(m), s%eig(m))
    call information_summary(s%mm, s%det, s%trace, s%sigma, s%eig, status)
    if (status /= 0) then
      status = MLID_ERR_INPUT
      msg = 'the information matrix of the design could not be decomposed'
      return
    end if
    allocate (names(c%nu), units(c%nu), none(0, n + 1))
    do k = 1, c%nu
      names(k) = input_name(c, k)
    end do
    if (allocated(c%ranking%names)) then
      if (size(c%ranking%names) > 0) call rank_job(c, f, g, h, r, gq, ks, cs, uc(:, 1:n), s, &
                                                   status, msg)
      if (status /= MLID_OK) return
    end if
    units = ''
    call record_text(names, units, t, uc, none, text, status, msg)
    if (status /= MLID_OK) return
    call write_file(c%out_file, text, status, msg)
    if (status /= MLID_OK) return
    s%inputs = names
    report = design_report(s)
    json = design_json(c%title, c%job, s)
  end subroutine design_job

  !> The design's F, G, H (through the servo) and noise: R = r dt, the
  !> spectral density of the sampled noise of variance r; the unknowns'
  !> blocks and columns as the servo moved them.
  subroutine design_matrices(c, f, g, h, r, gq, ks, cs, status, msg)
    type(case_t), intent(in) :: c
    real(wp), allocatable, intent(out) :: f(:, :), g(:, :), h(:, :), r(:, :), gq(:, :)
    integer, intent(out) :: ks(:), cs(:), status
    character(len=*), intent(out) :: msg
    type(layout_table_t) :: lt
    real(wp), allocatable :: rv(:)
    integer :: k

    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, status, msg)
    if (status /= MLID_OK) return
    call servo_model(block(lt, 'f'), block(lt, 'g'), block(lt, 'h'), c%gq, c%servo, c%ukind, &
                     c%ucol, f, g, h, gq, ks, cs)
    rv = pack(block(lt, 'r'), .true.)
    allocate (r(c%ny, c%ny))
    r = 0.0_wp
    do k = 1, c%ny
      r(k, k) = rv(k)*c%dt
    end do

  contains

    !> Block key of theta as a matrix (a vector: one column).
    function block(lt, key) result(a)
      type(layout_table_t), intent(in) :: lt
      character(len=*), intent(in) :: key
      real(wp), allocatable :: a(:, :)
      integer :: b
      b = findloc(lt%key, key, 1)
      a = reshape(c%theta(lt%off(b) + 1:lt%off(b) + lt%rows(b)*max(1, lt%cols(b))), &
                  [lt%rows(b), max(1, lt%cols(b))])
    end function block

  end subroutine design_matrices

  !> The input of the case's method on its cells (nu per cell, cell after
  !> cell), its mu (NaN for amplitude), information and the weights used.
  subroutine design_input(c, f, g, h, r, gq, ks, cs, n, s, u, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), r(:, :), gq(:, :)
    integer, intent(in) :: ks(:), cs(:), n
    type(design_summary_t), intent(inout) :: s
    real(wp), allocatable, intent(out) :: u(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(design_t) :: d
    real(wp) :: mu0, tc, trwm
    real(wp), allocatable :: lam0(:)
    integer :: cells

    s%mu = ieee_value(1.0_wp, ieee_quiet_nan)
    select case (c%design_method)
    case ('operator')             ! the largest eigenvalue of the operator (of the penalised one)
      allocate (u(n*c%nu))
      call penalised_design(c, f, g, h, r, gq, ks, cs, d, status, msg)
      if (status == MLID_OK) call operator_input(d, c%t_end, n/2, c%energy, u, s%mu, s%mm, &
                                                 status, msg)
    case ('equalised')
      allocate (u(n*c%nu), s%ratios(c%iterations + 1))
      call equalised_input(f, g, h, r, gq, ks, c%urow, cs, c%weights, c%t_end, n/2, c%energy, &
                           c%iterations, 1.0_wp, s%weights, u, s%mu, s%mm, s%ratios, s%nratio, &
                           status, msg)
    case ('riccati')
      ! mu of T by the secant of eq. 7.89 from the operator's; the input from
      ! the costate of the conjugate point (eqs 7.23-7.29)
      allocate (u(n*c%nu))
      call penalised_design(c, f, g, h, r, gq, ks, cs, d, status, msg)
      if (status == MLID_OK) call operator_mu(d, c%t_end, n/2, mu0, u, status, msg)
      if (status == MLID_OK) call mu_for_length(d, c%t_end, (1.0_wp - RICCATI_BRACKET)*mu0, &
                                                (1.0_wp + RICCATI_BRACKET)*mu0, s%mu, status, msg)
      allocate (lam0(d%na))
      if (status == MLID_OK) call transition_length(d, s%mu, 10.0_wp*c%t_end, tc, lam0, &
                                                    status, msg)
      if (status == MLID_OK) call costate_input(d, s%mu, c%t_end, lam0, n, u, status, msg)
      u = u*sqrt(c%energy)
      if (status == MLID_OK) call input_information(d, c%t_end, n, u, s%mm, status, msg)
    case default        ! amplitude: the widest cells no shorter than min_width that fit the steps
      cells = int(c%t_end/c%min_width + 1.0e-9_wp)
      do while (mod(n, cells) /= 0)
        cells = cells - 1
      end do
      allocate (u(cells*c%nu))
      call design_create(f, g, h, r, ks, c%urow, cs, c%weights, d, status, msg, gq)
      if (status == MLID_OK) call amplitude_limited_input(d, c%t_end, cells, c%peak, u, trwm, &
                                                          status, msg)
      if (status == MLID_OK) call input_information(d, c%t_end, cells, u, s%mm, status, msg)
    end select
  end subroutine design_input

  !> The design of case c on the (servo) model f, g, h with its state
  !> penalty K of report 7.6 (on the model's states; a servo's own states
  !> unpenalised), if any: tr(WM) - int x'Kx dt.
  subroutine penalised_design(c, f, g, h, r, gq, ks, cs, d, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), r(:, :), gq(:, :)
    integer, intent(in) :: ks(:), cs(:)
    type(design_t), intent(out) :: d
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: k(size(f, 1), size(f, 1))
    call design_create(f, g, h, r, ks, c%urow, cs, c%weights, d, status, msg, gq)
    if (status /= MLID_OK .or. all(c%kx == 0.0_wp)) return
    k = 0.0_wp
    k(1:c%nx, 1:c%nx) = c%kx
    call design_state_penalty(d, k, status, msg)
    if (status /= MLID_OK) msg = 'state_penalty: '//trim(msg)
  end subroutine penalised_design

  !> What the state penalty weighs, under the input u (its cells) from
  !> x(0) = 0: int x'Kx dt, and each state's peak |x| and rms over T
  !> (Simpson's rule on four exact samples per cell, as Python's
  !> InputDesign.state_integral).
  subroutine state_excursions(c, f, g, u, s, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: f(:, :), g(:, :), u(:)
    type(design_summary_t), intent(inout) :: s
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, parameter :: NS = 4
    real(wp), allocatable :: x(:, :), w(:), xx(:, :)
    integer :: j, np, ierr

    np = s%cells*NS + 1
    allocate (x(size(f, 1), np), w(np), xx(c%nx, c%nx), stat=ierr)
    if (ierr /= 0) then
      call no_memory('the states under the designed input', real(size(f, 1) + 1, wp)*np, &
                     status, msg)
      return
    end if
    call input_response(f, g, c%t_end, s%cells, NS, u, x, status, msg)
    if (status /= MLID_OK) return
    w = simpson_weights(np, c%t_end)
    do j = 1, c%nx
      xx(:, j) = matmul(x(1:c%nx, :), w*x(j, :))
    end do
    s%kx = c%kx
    s%xint = sum(c%kx*xx)
    s%xpeak = maxval(abs(x(1:c%nx, :)), dim=2)
    s%xrms = sqrt(max([(xx(j, j), j=1, c%nx)], 0.0_wp)/c%t_end)
  end subroutine state_excursions
  !> The candidates of &design ranked beside the design's input uc (on the
  !> record's steps), each at its energy or peak; the states (a servo's
  !> after the model's) and outputs labelled.
  subroutine rank_job(c, f, g, h, r, gq, ks, cs, uc, s, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), r(:, :), gq(:, :), uc(:, :)
    integer, intent(in) :: ks(:), cs(:)
    type(design_summary_t), intent(inout) :: s
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(design_t) :: d
    real(wp) :: level
    integer :: k, j

    call design_create(f, g, h, r, ks, c%urow, cs, c%weights, d, status, msg, gq)
    if (status /= MLID_OK) return
    level = merge(s%energy, s%peak, to_lower(c%ranking%compare) == 'energy')
    call rank_candidates(d, f, g, h, f(1:c%nx, 1:c%nx), c%t_end, size(uc, 2), c%ranking, level, &
                         reshape(uc, [size(uc)]), s%ranking, status, msg)
    if (status /= MLID_OK) return
    allocate (s%states(size(f, 1)), s%outputs(c%ny))
    do k = 1, c%nx
      s%states(k) = 'x'//itoa(k)
    end do
    j = c%nx
    do k = 1, c%nu
      if (.not. c%servo(k) > 0.0_wp) cycle
      j = j + 1
      s%states(j) = trim(input_name(c, k))//' servo'
    end do
    do k = 1, c%ny
      s%outputs(k) = 'y'//itoa(k)
      if (allocated(c%output_names)) then
        if (size(c%output_names) == c%ny) s%outputs(k) = c%output_names(k)
      end if
    end do
  end subroutine rank_job

  !> monte_carlo: runs seed, seed + 1, ... simulated from the truth with
  !> the input of input_file, each fitted from &model's values.
  subroutine monte_carlo_job(c, report, json, status, msg, around, progress)
    type(case_t), intent(in) :: c
    character(len=:), allocatable, intent(inout) :: report, json
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(around_t), intent(in), optional :: around
    type(progress_t), intent(inout), optional :: progress
    real(wp), allocatable :: t(:), u(:, :), y(:, :), est(:, :), sig(:, :), info(:, :, :)
    integer, allocatable :: iters(:), run_status(:)
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    type(mc_summary_t) :: s
    integer :: nf

    call case_time_input(c, t, u, status, msg)
    if (status /= MLID_OK) return
    nf = count(c%isfree > 0)
    allocate (y(c%ny, size(t)))
    y = 0.0_wp
    call setup(c%mkind, c%nx, c%nu, c%ny, c%nw, c%theta, c%isfree, c%tie, c%iconst, c%rconst, &
               t, u, y, c%iopt, c%ropt, nf, m, opt, pm, status, msg)
    if (status /= MLID_OK) return
    allocate (est(nf, c%runs), sig(nf, c%runs), info(nf, nf, c%runs), iters(c%runs), &
              run_status(c%runs))
    if (present(around)) then
      if (associated(around%begin)) call around%begin()
    end if
    call monte_carlo(m, c%theta_true, c%theta, pm, t, u, opt, c%seed, est, sig, iters, &
                     run_status, info, progress)
    if (present(around)) then
      if (associated(around%end)) call around%end()
    end if
    s%labels = c%labels
    s%truth = c%theta_true(pm%ifree)
    s%start = c%theta(pm%ifree)
    s%seed = c%seed
    s%input_file = c%input_file
    s%samples = size(t)
    s%runs = c%runs
    allocate (s%mean(nf), s%sample_sigma(nf), s%cr_sigma(nf))
    call mc_statistics(est, sig, info, run_status, s%ok, s%mean, s%sample_sigma, s%cr_sigma, &
                       s%cov_trace, s%cov_det, s%info_trace, s%info_det)
    report = mc_report(s)
    json = mc_json(c%title, c%job, s)
  end subroutine monte_carlo_job

  !> online: the estimator over the case's record (its files one after
  !> another, run straight across the joins), the history written to out
  !> (t, each estimate, each sigma; from the first point that determines
  !> them all, so that &data reads it), the report and JSON from the last
  !> point: estimates, sigma, when each converged (within 2 sigma of its
  !> final value from then on) and the estimator's own measure (FTR: each
  !> equation's residual variance; the filters: R's diagonal).
  subroutine online_job(c, report, json, status, msg)
    type(case_t), intent(in) :: c
    character(len=:), allocatable, intent(inout) :: report, json
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: t(:), u(:, :), y(:, :)
    type(online_summary_t) :: o
    integer(int64) :: clock0, clock1, rate

    call case_record(c, t, u, y, status, msg)
    if (status /= MLID_OK) return
    call system_clock(clock0, rate)
    if (c%online_estimator == 'ftr') then
      call online_ftr(c, t, u, y, o, status, msg)
    else if (c%online_estimator == 'rls') then
      call online_rls(c, t, u, y, o, status, msg)
    else
      call online_filter(c, t, u, y, o, status, msg)
    end if
    call system_clock(clock1)
    if (status /= MLID_OK) return
    if (c%online_timing) o%per_sample = real(clock1 - clock0, wp)/real(max(rate, 1_int64), wp)/ &
                                        size(t)
    o%estimator = c%online_estimator
    o%samples = size(t)
    if (size(t) > 1) o%dt = (t(size(t)) - t(1))/(size(t) - 1)
    o%out = c%out_file
    o%converged = convergence_times(o%t, o%est, o%sig, 2.0_wp)
    call write_history(c%out_file, o, status, msg)
    if (status /= MLID_OK) return
    report = online_report(o)
    json = online_json(c%title, c%job, o)
  end subroutine online_job

  !> Fourier-transform regression's solves (mlid_ftr) into o.
  subroutine online_ftr(c, t, u, y, o, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(online_summary_t), intent(inout) :: o
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(ftr_settings_t) :: s
    type(options_t) :: band
    integer :: m, np
    band%n_freq = c%online_nfreq          ! the frequency-domain methods' grid
    band%f_min = c%online_band(1)
    band%f_max = c%online_band(2)
    s%w = 2.0_wp*PI*freq_grid(band)
    s%every = c%online_every
    s%trim = c%online_trim
    s%first = c%online_first
    s%lambda = c%online_lambda
    m = size(t)/s%every
    np = c%nx*(c%nx + c%nu)
    allocate (o%t(m), o%est(np, m), o%sig(np, m), o%s2(c%nx, m))
    call ftr_run(t, y, u, s, o%t, o%est, o%sig, o%s2, status, msg)
    if (status /= MLID_OK) return
    o%names = ftr_labels(c)
    o%measure = 'equation error variance'
    o%settings = itoa(m)//' solves (every '//itoa(s%every)//' samples), '// &
                 itoa(c%online_nfreq)//' frequencies '// &
                 trim(adjustl(es_text(c%online_band(1), 10, 3)))//' to '// &
                 trim(adjustl(es_text(c%online_band(2), 10, 3)))//' Hz'
  end subroutine online_ftr

  !> An augmented-state filter (mlid_online_ekf, mlid_online_ukf) over the
  !> record from &model's values, its free model parameters estimated;
  !> the parameters' rows of its history into o.
  subroutine online_filter(c, t, u, y, o, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(online_summary_t), intent(inout) :: o
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    class(model_t), allocatable :: m
    type(layout_t) :: l
    type(filter_settings_t) :: s
    real(wp), allocatable :: est(:, :), sig(:, :), rhist(:, :)
    integer, allocatable :: ifree(:)
    integer :: n, ierr

    call model_create(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, m, status, msg)
    if (status /= MLID_OK) return
    l = model_layout(m)
    ifree = free_indices(c%isfree(1:l%np))          ! the model's own, in the order of free
    n = c%nx + size(ifree)
    s%p0 = c%online_p0
    s%q = c%online_q
    s%r = c%theta(l%or + 1:l%or + c%ny)
    s%qw = c%theta(l%oq + 1:l%oq + c%nw)
    s%delta = c%online_delta
    s%r_fade = c%online_rfade
    if (c%online_estimator == 'efrls') s%forget = c%online_lambda
    s%hold = c%iopt(4) == 1
    s%nsub = max(1, c%iopt(5))
    allocate (est(n, size(t)), sig(n, size(t)), rhist(c%ny, size(t)), stat=ierr)
    if (ierr /= 0) then
      call no_memory('the filter''s history', real(2*n + c%ny, wp)*size(t), status, msg)
      return
    end if
    rhist = 0.0_wp
    associate (p => c%theta(1:l%np), x0 => c%theta(l%ox0 + 1:l%ox0 + c%nx), &
               bias => c%theta(l%obias + 1:l%obias + c%ny))
      if (c%online_estimator == 'ekf' .or. c%online_estimator == 'efrls') then
        call ekf_run(m, p, ifree, x0, bias, t, u, y, s, est, sig, rhist, status, msg)
      else
        call ukf_run(m, p, ifree, x0, bias, t, u, y, s, c%online_estimator == 'ukf_augmented', &
                     est, sig, rhist, status, msg)
      end if
    end associate
    if (status /= MLID_OK) return
    o%t = t
    o%est = est(c%nx + 1:, :)
    o%sig = sig(c%nx + 1:, :)
    o%s2 = rhist
    o%names = c%labels(c%isfree(ifree))
    o%measure = 'R diagonal'
    o%settings = itoa(size(t))//' updates'
  end subroutine online_filter

  !> The history (t, the estimates, their sigma_) from the first point
  !> that determines every estimate, so that &data reads it.
  subroutine write_history(path, o, status, msg)
    character(len=*), intent(in) :: path
    type(online_summary_t), intent(in) :: o
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: vals(:, :), none(:, :)
    character(len=NAMELEN), allocatable :: names(:)
    character(len=UNITLEN), allocatable :: units(:)
    character(len=:), allocatable :: text
    integer :: np, k, k0
    np = size(o%names)
    k0 = findloc([(all(ieee_is_finite(o%est(:, k))), k=1, size(o%t))], .true., 1)
    if (k0 == 0) then
      status = MLID_ERR_INPUT
      msg = 'online: no point of the history determined the parameters (too little excitation)'
      return
    end if
    allocate (names(2*np), units(2*np), none(0, size(o%t) - k0 + 1), vals(2*np, size(o%t) - k0 + 1))
    names(1:np) = o%names
    do k = 1, np
      names(np + k) = 'sigma_'//trim(o%names(k))
    end do
    units = ''
    vals(1:np, :) = o%est(:, k0:)
    vals(np + 1:, :) = o%sig(:, k0:)
    call record_text(names, units, o%t(k0:), vals, none, text, status, msg)
    if (status == MLID_OK) call write_file(path, text, status, msg)
  end subroutine write_history

  !> The labels of F's and G's entries in the regression's order (row i
  !> of F, then of G), from the case's labels of its free parameters (the
  !> deck's names, else f(i,j)); theta holds F, then G, column by column.
  function ftr_labels(c) result(names)
    type(case_t), intent(in) :: c
    character(len=NAMELEN), allocatable :: names(:)
    type(layout_table_t) :: lt
    integer :: i, j, k, status, fo, go
    character(len=256) :: msg
    call layout_of(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, lt, status, msg)
    fo = lt%off(findloc(lt%key, 'f', 1))
    go = lt%off(findloc(lt%key, 'g', 1))
    allocate (names(c%nx*(c%nx + c%nu)))
    k = 0
    do i = 1, c%nx
      do j = 1, c%nx
        k = k + 1
        names(k) = c%labels(c%isfree(fo + (j - 1)*c%nx + i))
      end do
      do j = 1, c%nu
        k = k + 1
        names(k) = c%labels(c%isfree(go + (j - 1)*c%nx + i))
      end do
    end do
  end function ftr_labels

  !> Input k's name: &model's, else u<k>.
  function input_name(c, k) result(name)
    type(case_t), intent(in) :: c
    integer, intent(in) :: k
    character(len=NAMELEN) :: name
    name = 'u'//itoa(k)
    if (allocated(c%input_names)) then
      if (size(c%input_names) == c%nu) name = c%input_names(k)
    end if
  end function input_name

end module mlid_jobs
