!> Monte Carlo identification: simulate a record from the truth with a new
!> noise seed, fit it from the start values, keep the estimates and their
!> Cramer-Rao standard deviations; repeat.
module mlid_monte_carlo
  use mlid_kinds, only: wp, MLID_OK
  use mlid_models, only: model_t
  use mlid_options, only: options_t
  use mlid_params, only: param_map_t
  use mlid_simulate, only: simulate_outputs
  use mlid_newton, only: fit_result_t, extras_t, newton_fit
  implicit none
  private
  public :: monte_carlo

contains

  !> Run r uses seed seed0 + r - 1.  A failed run is recorded in
  !> run_status(r) and does not stop the others.
  subroutine monte_carlo(m, theta_true, theta_start, pm, t, u, opt, seed0, est, sig, iters, &
                         run_status, info)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta_true(:), theta_start(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :)
    type(options_t), intent(in) :: opt
    integer, intent(in) :: seed0
    real(wp), intent(out) :: est(:, :), sig(:, :)
    integer, intent(out) :: iters(:), run_status(:)
    real(wp), intent(out), optional :: info(:, :, :)   !< each run's information matrix
    real(wp) :: y(m%ny, size(t)), x(m%nx, size(t))
    type(fit_result_t) :: res
    type(extras_t) :: none
    character(len=256) :: msg
    integer :: r, k

    est = 0.0_wp
    sig = 0.0_wp
    iters = 0
    if (present(info)) info = 0.0_wp
    do r = 1, size(run_status)
      call simulate_outputs(m, theta_true, t, u, opt, seed0 + r - 1, y, x, run_status(r), msg)
      if (run_status(r) /= MLID_OK) cycle
      call newton_fit(m, theta_start, pm, t, u, y, opt, none, res, run_status(r), msg)
      if (.not. allocated(res%theta)) cycle
      est(:, r) = res%theta(pm%ifree)
      do k = 1, pm%nf
        sig(k, r) = sqrt(max(0.0_wp, res%cov(k, k)))
      end do
      iters(r) = res%niter
      if (present(info) .and. allocated(res%info)) info(:, :, r) = res%info
    end do
  end subroutine monte_carlo

end module mlid_monte_carlo
