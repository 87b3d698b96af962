!> Monte Carlo identification: simulate a record from the truth with a new
!> noise seed, fit it from the start values, keep the estimates and their
!> Cramer-Rao standard deviations; repeat.
module mlid_monte_carlo
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INTERRUPTED, MLID_ERR_MEMORY
  use mlid_interrupt, only: interrupt_requested
  use mlid_models, only: model_t, layout_t
  use mlid_options, only: options_t
  use mlid_params, only: param_map_t
  use mlid_simulate, only: simulate_outputs, simulate_noise
  use mlid_newton, only: fit_result_t, extras_t
  use mlid_fit_driver, only: fit_method
  use mlid_linalg, only: sym_eig
  use mlid_progress, only: progress_t, progress_start, progress_to, progress_stop
  implicit none
  private
  public :: monte_carlo, mc_statistics

contains

  !> Run r uses seed seed0 + r - 1.  A failed run is recorded in
  !> run_status(r) and does not stop the others; a Ctrl-C does, and so does
  !> a record too long for the memory: the run it stopped and those not run
  !> have its status (MLID_ERR_INTERRUPTED, MLID_ERR_MEMORY).  Without process noise
  !> every run's states are the same: the record without measurement noise
  !> is simulated once and each run adds its own draw (simulate_noise, the
  !> draws of simulate_outputs: the same record to the bit).  progress
  !> counts the runs ended (mlid_progress).
  subroutine monte_carlo(m, theta_true, theta_start, pm, t, u, opt, seed0, est, sig, iters, &
                         run_status, info, progress)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta_true(:), theta_start(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :)
    type(options_t), intent(in) :: opt
    integer, intent(in) :: seed0
    real(wp), intent(out) :: est(:, :), sig(:, :)
    integer, intent(out) :: iters(:), run_status(:)
    real(wp), intent(out), optional :: info(:, :, :)   !< each run's information matrix
    type(progress_t), intent(inout), optional :: progress
    real(wp), allocatable :: y(:, :), x(:, :), yclean(:, :)
    real(wp), allocatable :: w(:, :), v(:, :)
    type(fit_result_t) :: res
    type(extras_t) :: none
    character(len=256) :: msg
    integer :: r, k, cstat
    logical :: quiet

    est = 0.0_wp
    sig = 0.0_wp
    iters = 0
    if (present(info)) info = 0.0_wp
    allocate (y(m%ny, size(t)), x(m%nx, size(t)), yclean(m%ny, size(t)), stat=k)
    if (k /= 0) then
      run_status = MLID_ERR_MEMORY
      return
    end if
    quiet = no_process_noise(theta_true, pm%l)
    call progress_start(progress, 'monte carlo', size(run_status), .true.)
    if (quiet) call clean_record(cstat)
    do r = 1, size(run_status)
      call progress_to(progress, r - 1)
      if (interrupt_requested()) then
        run_status(r:) = MLID_ERR_INTERRUPTED
        exit
      end if
      if (quiet) then
        run_status(r) = cstat
        if (cstat == MLID_OK) call simulate_noise(m, theta_true, size(t), seed0 + r - 1, .false., &
                                                  w, v, run_status(r), msg)
        if (run_status(r) == MLID_OK) y = yclean + v
      else
        call simulate_outputs(m, theta_true, t, u, opt, seed0 + r - 1, y, x, run_status(r), msg)
      end if
      if (run_status(r) == MLID_ERR_MEMORY .or. run_status(r) == MLID_ERR_INTERRUPTED) then
        run_status(r + 1:) = run_status(r)
        exit
      end if
      if (run_status(r) /= MLID_OK) cycle
      call fit_method(m, theta_start, pm, t, u, y, opt, none, res, run_status(r), msg, &
                      plain_bound=.true.)
      if (run_status(r) == MLID_ERR_MEMORY .or. run_status(r) == MLID_ERR_INTERRUPTED) then
        run_status(r + 1:) = run_status(r)
        exit
      end if
      if (.not. allocated(res%theta)) cycle
      est(:, r) = res%theta(pm%ifree)
      do k = 1, pm%nf
        sig(k, r) = sqrt(max(0.0_wp, res%cov(k, k)))
      end do
      iters(r) = res%niter
      if (present(info) .and. allocated(res%info)) info(:, :, r) = res%info
    end do
    call progress_to(progress, r - 1)     ! r: the run that stopped it, or one past the last
    call progress_stop(progress)

  contains

    !> The truth's record with its measurement noise variances zero (the
    !> draws then add exact zeros), the noise checked as simulate_outputs
    !> checks it.
    subroutine clean_record(stat)
      integer, intent(out) :: stat
      real(wp) :: th(size(theta_true))
      th = theta_true
      th(pm%l%or + 1:pm%l%or + m%ny) = 0.0_wp
      call simulate_noise(m, theta_true, size(t), seed0, .false., w, v, stat, msg)
      if (stat == MLID_OK) call simulate_outputs(m, th, t, u, opt, seed0, yclean, x, stat, msg)
    end subroutine clean_record

  end subroutine monte_carlo

  !> Whether theta has no process noise: q and s zero (the process-noise
  !> draws are then exact zeros).
  pure logical function no_process_noise(theta, l)
    real(wp), intent(in) :: theta(:)
    type(layout_t), intent(in) :: l
    no_process_noise = all(theta(l%oq + 1:l%oq + l%nw) == 0.0_wp) .and. &
                       all(theta(l%os + 1:l%os + l%nw*l%ny) == 0.0_wp)
  end function no_process_noise

  !> Table 8.1's statistics over the runs that succeeded (run_status 0, nok
  !> of them): the mean estimate, the sample sigma (n - 1), the mean
  !> Cramer-Rao sigma, trace and det of the sample covariance (n - 1), trace
  !> and det of the mean information.  NaN where too few runs.  The one
  !> summary of both front ends: the deck job and mlid.monte_carlo.
  subroutine mc_statistics(est, sig, info, run_status, nok, mean, sample_sigma, cr_sigma, &
                           cov_trace, cov_det, info_trace, info_det)
    real(wp), intent(in) :: est(:, :), sig(:, :), info(:, :, :)   !< (nf, runs), (nf, nf, runs)
    integer, intent(in) :: run_status(:)
    integer, intent(out) :: nok
    real(wp), intent(out) :: mean(:), sample_sigma(:), cr_sigma(:)
    real(wp), intent(out) :: cov_trace, cov_det, info_trace, info_det
    real(wp) :: cov(size(est, 1), size(est, 1)), mi(size(est, 1), size(est, 1))
    real(wp) :: d(size(est, 1)), nan
    logical :: ok(size(run_status))
    integer :: nf, k, l, n

    nf = size(est, 1)
    nan = ieee_value(1.0_wp, ieee_quiet_nan)
    ok = run_status == MLID_OK
    n = count(ok)
    nok = n
    mean = nan
    sample_sigma = nan
    cr_sigma = nan
    cov_det = nan
    cov_trace = nan
    info_trace = nan
    info_det = nan
    if (n == 0) return
    do k = 1, nf
      mean(k) = sum(est(k, :), mask=ok)/n
      cr_sigma(k) = sum(sig(k, :), mask=ok)/n
      do l = 1, nf
        mi(k, l) = sum(info(k, l, :), mask=ok)/n
      end do
    end do
    info_trace = sum([(mi(k, k), k=1, nf)])
    info_det = det_sym(mi)
    if (n < 2) return
    do k = 1, nf
      do l = 1, nf
        cov(k, l) = sum((est(k, :) - mean(k))*(est(l, :) - mean(l)), mask=ok)/(n - 1)
      end do
      d(k) = cov(k, k)
    end do
    sample_sigma = sqrt(d)
    cov_trace = sum(d)
    cov_det = det_sym(cov)
  end subroutine mc_statistics

  !> det of a symmetric matrix: the product of its eigenvalues.
  real(wp) function det_sym(a)
    real(wp), intent(in) :: a(:, :)
    real(wp) :: ev(size(a, 1)), vec(size(a, 1), size(a, 1))
    integer :: info
    call sym_eig(0.5_wp*(a + transpose(a)), ev, vec, info)
    det_sym = product(ev)
    if (info /= 0) det_sym = ieee_value(1.0_wp, ieee_quiet_nan)
  end function det_sym

end module mlid_monte_carlo
