!> Modified Newton-Raphson (Gauss-Newton) maximisation of the likelihood,
!> report §4.3 and §4.6: step from the eigen-decomposition of the
!> information matrix (block 6), step halving when the cost rises (blocks
!> 8-9), stop on cost change, step size or gradient (§8.2.3).
module mlid_newton
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_SINGULAR, MLID_ERR_NOCONV, MLID_ERR_INTERNAL, &
                        STOP_NONE, STOP_COST, STOP_STEP, STOP_GRAD, STOP_MAXITER, &
                        STOP_NO_DECREASE, STOP_FAILED
  use mlid_linalg, only: info_inverse
  use mlid_equation_error, only: equation_error
  use mlid_models, only: model_t
  use mlid_options, only: options_t
  use mlid_likelihood, only: likelihood
  use mlid_params, only: param_map_t, apply_ties
  implicit none
  private
  public :: fit_result_t, newton_fit

  type :: fit_result_t
    real(wp), allocatable :: theta_start(:) !< where the iteration started
    real(wp), allocatable :: theta(:)       !< final parameters (all, fixed ones unchanged)
    real(wp), allocatable :: grad(:)        !< gradient at theta (free)
    real(wp), allocatable :: info(:, :)     !< information matrix at theta (free)
    real(wp), allocatable :: cov(:, :)      !< inverse of info: Cramer-Rao covariance (free)
    real(wp), allocatable :: eigval(:)      !< eigenvalues of the normalised info, ascending
    real(wp), allocatable :: rhat(:, :)     !< measurement noise covariance estimate
    real(wp), allocatable :: yhat(:, :)     !< model outputs at theta
    real(wp), allocatable :: cost_hist(:)   !< cost before iteration 1, then after each
    real(wp) :: cost = 0.0_wp
    integer :: niter = 0
    integer :: reason = STOP_NONE
    integer :: bad_param = 0                !< free index dominating a singular direction
    logical :: converged = .false.
  end type fit_result_t

contains

  !> Fit the free parameters of theta0 (map pm) by maximum likelihood, with
  !> the method of opt.  On a non-zero status res still holds the last iterate.
  subroutine newton_fit(m, theta0, pm, t, u, y, opt, res, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta0(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(options_t), intent(in) :: opt
    type(fit_result_t), intent(out) :: res
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: nf, ny, nt, it, ih, tstat, ndrop
    real(wp) :: step(pm%nf), trial(size(theta0)), best(size(theta0)), ee_sigma(pm%nf)
    real(wp) :: jt, jbest, scale, decrement, dj
    real(wp), allocatable :: rt(:, :), yt(:, :), rbest(:, :)
    character(len=len(msg)) :: tmsg

    nf = pm%nf
    ny = m%ny
    nt = size(t)
    allocate (res%grad(nf), res%info(nf, nf), res%cov(nf, nf), res%eigval(nf), &
              res%rhat(ny, ny), res%yhat(ny, nt), res%cost_hist(opt%max_iter + 1))
    allocate (rt(ny, ny), yt(ny, nt), rbest(ny, ny))
    res%theta = theta0
    call apply_ties(pm%tie, res%theta)
    res%cost_hist = 0.0_wp
    if (opt%startup == 1) then
      call equation_error(m, theta0, pm, t, u, y, res%theta, ee_sigma, status, msg)
      if (status /= MLID_OK) then
        res%reason = STOP_FAILED
        return
      end if
    end if
    res%theta_start = res%theta

    call likelihood(m, res%theta, pm, t, u, y, opt, res%cost, res%rhat, res%yhat, &
                    status, msg, res%grad, res%info)
    if (status /= MLID_OK) then
      res%reason = STOP_FAILED
      return
    end if
    res%cost_hist(1) = res%cost

    do it = 1, opt%max_iter
      call newton_step(res, opt%rcond, step, decrement, ndrop, status, msg)
      if (status /= MLID_OK) then
        res%reason = STOP_FAILED
        return
      end if
      if (decrement <= opt%tol_grad) then
        res%reason = STOP_GRAD
        exit
      end if

      ! Full step first, then halve while the cost does not decrease.
      jbest = huge(1.0_wp)
      scale = 1.0_wp
      do ih = 0, opt%halvings
        trial = res%theta
        trial(pm%ifree) = trial(pm%ifree) + scale*step
        call apply_ties(pm%tie, trial)
        call likelihood(m, trial, pm, t, u, y, opt, jt, rt, yt, tstat, tmsg)
        if (tstat == MLID_OK .and. ieee_is_finite(jt) .and. jt < jbest) then
          jbest = jt
          best = trial
          rbest = rt
        end if
        if (jbest < res%cost) exit
        scale = 0.5_wp*scale
      end do

      dj = res%cost - jbest
      if (.not. (dj > 0.0_wp)) then
        ! No decrease: converged if the cost is flat to tolerance, else stuck.
        if (jbest < huge(1.0_wp) .and. abs(dj) <= opt%tol_cost*max(1.0_wp, abs(res%cost))) then
          res%reason = STOP_COST
        else
          res%reason = STOP_NO_DECREASE
        end if
        exit
      end if

      res%niter = it
      res%theta = best
      call likelihood(m, res%theta, pm, t, u, y, opt, res%cost, res%rhat, res%yhat, &
                      status, msg, res%grad, res%info)
      if (status /= MLID_OK) then
        res%reason = STOP_FAILED
        return
      end if
      res%cost_hist(it + 1) = res%cost

      if (dj <= opt%tol_cost*max(1.0_wp, abs(res%cost))) then
        res%reason = STOP_COST
        exit
      end if
      if (scale*norm2(step) <= opt%tol_step*norm2(res%theta(pm%ifree))) then
        res%reason = STOP_STEP
        exit
      end if
    end do
    if (res%reason == STOP_NONE) res%reason = STOP_MAXITER
    res%converged = any(res%reason == [STOP_COST, STOP_STEP, STOP_GRAD])

    ! Cramer-Rao bound at the final estimate.
    call info_inverse(res%info, opt%rcond, res%cov, res%eigval, ndrop, res%bad_param, status, msg)
    if (status /= MLID_OK) return
    if (ndrop > 0) then
      status = MLID_ERR_SINGULAR
      write (msg, '(a,i0,a,es9.2,a,i0,a)') 'information matrix singular (', ndrop, &
        ' eigenvalue(s) of the normalised matrix below', opt%rcond, ' of the largest): free parameter ', &
        res%bad_param, ' is not identifiable from these data'
    else if (.not. res%converged) then
      status = MLID_ERR_NOCONV
      write (msg, '(a,i0,a)') 'not converged after ', res%niter, ' iterations: ' // &
        trim(merge('no cost decrease after all step halvings', &
                   'iteration limit reached                 ', &
                   res%reason == STOP_NO_DECREASE))
    end if
  end subroutine newton_fit

  !> Newton step -M^-1 g through the eigen-decomposition of M, with the
  !> directions whose eigenvalues fall below rcond*max left out, and the
  !> Newton decrement sqrt(g' M^-1 g).
  subroutine newton_step(res, rcond, step, decrement, ndrop, status, msg)
    type(fit_result_t), intent(in) :: res
    real(wp), intent(in) :: rcond
    real(wp), intent(out) :: step(:), decrement
    integer, intent(out) :: ndrop, status
    character(len=*), intent(out) :: msg
    real(wp) :: cov(size(step), size(step)), w(size(step))
    integer :: bad

    call info_inverse(res%info, rcond, cov, w, ndrop, bad, status, msg)
    if (status /= MLID_OK) return
    step = -matmul(cov, res%grad)
    decrement = sqrt(max(0.0_wp, -dot_product(res%grad, step)))
  end subroutine newton_step

end module mlid_newton
