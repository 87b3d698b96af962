!> Modified Newton-Raphson (Gauss-Newton) maximisation of the likelihood,
!> report §4.3 and §4.6: step from the eigen-decomposition of the
!> information matrix (block 6), step halving when the cost rises (blocks
!> 8-9), stop on cost change, step size or gradient (§8.2.3).
module mlid_newton
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_SINGULAR, MLID_ERR_NOCONV, MLID_ERR_INTERNAL, &
                        STOP_NONE, STOP_COST, STOP_STEP, STOP_GRAD, STOP_MAXITER, &
                        STOP_NO_DECREASE, STOP_FAILED
  use mlid_linalg, only: info_inverse, info_eig, eig_inverse
  use mlid_equation_error, only: equation_error
  use mlid_models, only: model_t
  use mlid_options, only: options_t
  use mlid_likelihood, only: likelihood
  use mlid_params, only: param_map_t, apply_ties
  implicit none
  private
  public :: fit_result_t, extras_t, newton_fit

  !> How much a higher rank must lower the cost (a negative log-likelihood)
  !> to be taken in the rank-deficient search: a likelihood-ratio test at 5%
  !> for one more direction, chi-square(1) 95% point 3.841 over 2.
  real(wp), parameter :: RANK_GAIN = 0.5_wp*3.841_wp

  !> The estimator options of report §4.6 beyond plain Newton-Raphson, over
  !> the free parameters: a priori values and weight (block 7), bounds
  !> (blocks 11-12).  Unallocated: not used.
  type :: extras_t
    real(wp), allocatable :: prior(:)       !< a priori values (nf)
    real(wp), allocatable :: weight(:, :)   !< a priori weight matrix (nf, nf), positive semi-definite
    real(wp), allocatable :: lower(:), upper(:)   !< bounds (nf)
  end type extras_t

  type :: fit_result_t
    real(wp), allocatable :: theta_start(:) !< where the iteration started
    real(wp), allocatable :: theta(:)       !< final parameters (all, fixed ones unchanged)
    real(wp), allocatable :: grad(:)        !< gradient of the likelihood at theta (free)
    real(wp), allocatable :: info(:, :)     !< information matrix at theta, with the prior weight
    real(wp), allocatable :: cov(:, :)      !< its (rank-r) inverse: Cramer-Rao covariance (free)
    real(wp), allocatable :: eigval(:)      !< eigenvalues of the normalised info, ascending
    real(wp), allocatable :: eigvec(:, :)   !< its eigenvectors (columns)
    real(wp), allocatable :: rhat(:, :)     !< measurement noise covariance estimate
    real(wp), allocatable :: yhat(:, :)     !< model outputs at theta
    real(wp), allocatable :: cost_hist(:)   !< likelihood before iteration 1, then after each
    real(wp) :: cost = 0.0_wp               !< negative log-likelihood (without the prior term)
    integer :: niter = 0
    integer :: reason = STOP_NONE
    integer :: rank = 0                     !< highest rank of any step: the directions estimated
    integer :: bad_param = 0                !< free index dominating a singular direction
    logical :: converged = .false.
  end type fit_result_t

contains

  !> Fit the free parameters of theta0 (map pm) by maximum likelihood, with
  !> the method of opt and the options in ex.  On a non-zero status res still
  !> holds the last iterate.
  subroutine newton_fit(m, theta0, pm, t, u, y, opt, ex, res, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta0(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(options_t), intent(in) :: opt
    type(extras_t), intent(in) :: ex
    type(fit_result_t), intent(out) :: res
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: nf, ny, nt, it, ih, tstat, ndrop, rank, rmin, rtop
    type(fit_result_t) :: saved
    logical :: better
    real(wp) :: step(pm%nf), trial(size(theta0)), best(size(theta0)), ee_sigma(pm%nf)
    real(wp) :: g(pm%nf), mt(pm%nf, pm%nf), cov(pm%nf, pm%nf), w(pm%nf), v(pm%nf, pm%nf)
    real(wp) :: sc(pm%nf), unit(pm%nf), scr(pm%nf), wr(pm%nf), vr(pm%nf, pm%nf)
    real(wp) :: jt, jbest, jnow, scale, decrement, dj, s, best_step, jsaved
    real(wp), allocatable :: rt(:, :), yt(:, :)
    character(len=len(msg)) :: tmsg

    nf = pm%nf
    ny = m%ny
    nt = size(t)
    allocate (res%grad(nf), res%info(nf, nf), res%cov(nf, nf), res%eigval(nf), res%eigvec(nf, nf), &
              res%rhat(ny, ny), res%yhat(ny, nt), res%cost_hist(opt%max_iter + 1))
    allocate (rt(ny, ny), yt(ny, nt))
    res%theta = theta0
    call apply_ties(pm%tie, res%theta)
    res%cost_hist = 0.0_wp
    res%rank = nf
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
    rmin = nf
    if (opt%rank_min > 0) rmin = min(opt%rank_min, nf)
    rtop = nf
    if (opt%rank_max > 0) rtop = min(nf, opt%rank_max)
    ! Units of the rank-deficient search: the start values' magnitudes (the
    ! step is then the least relative change, and a weak combination stays
    ! at its a priori value, §5.3.6).  A parameter starting at zero has no
    ! size to be relative to: it gets the median size-to-sigma ratio of the
    ! others, so that it is neither dropped nor favoured for that alone.
    unit = search_units(res%theta(pm%ifree), [(res%info(ih, ih), ih=1, nf)])
    s = 1.0_wp
    it = 0

    if (opt%rank_rule == 1 .and. rmin < rtop) then
      ! Staged: converge at the minimum rank, then free one more direction
      ! at a time and keep it only if the converged likelihood improves by
      ! more than RANK_GAIN; otherwise go back to the last accepted fit.
      rank = rmin
      call iterate(rank, rank)
      do while (rank < rtop .and. status == MLID_OK .and. res%converged)
        saved = res
        jsaved = res%cost + prior_cost(res%theta, s)
        call iterate(rank + 1, rank + 1)
        if (status /= MLID_OK) return
        if (jsaved - (res%cost + prior_cost(res%theta, s)) <= RANK_GAIN) then
          res = saved
          exit
        end if
        rank = rank + 1
      end do
      res%rank = rank
    else
      call iterate(min(rmin, rtop), rtop)
    end if
    if (status /= MLID_OK) return

    res%converged = any(res%reason == [STOP_COST, STOP_STEP, STOP_GRAD])

    ! Cramer-Rao bound at the final estimate, with the prior's weight and
    ! the rank of the last step.
    if (allocated(ex%weight)) res%info = res%info + s*ex%weight
    call info_inverse(res%info, opt%rcond, res%cov, res%eigval, ndrop, res%bad_param, status, &
                      msg, res%rank, res%eigvec)
    if (status /= MLID_OK) return
    if (res%rank < nf) then   ! the covariance of the directions estimated, in the search's units
      call info_eig(res%info, scr, wr, vr, status, msg, unit)
      if (status /= MLID_OK) return
      call eig_inverse(scr, wr, vr, opt%rcond, res%rank, res%cov, ih, tstat)
    end if
    if (ndrop > 0 .and. opt%rank_min == 0) then     ! singular, and no rank-deficient solution asked
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

  contains

    !> |theta_k|, or for a zero start value the marginal sigma 1/sqrt(M_kk)
    !> times the median |theta_j| sqrt(M_jj) of the others.
    function search_units(th, dg) result(un)
      real(wp), intent(in) :: th(:), dg(:)
      real(wp) :: un(size(th)), snr(size(th)), med
      logical :: sized(size(th))
      integer :: k, n, j
      sized = th /= 0.0_wp .and. dg > 0.0_wp
      un = abs(th)
      n = count(sized)
      med = 1.0_wp
      if (n > 0) then
        snr(:n) = pack(abs(th)*sqrt(max(dg, 0.0_wp)), sized)
        do k = 2, n             ! insertion sort: n is a handful
          med = snr(k)
          j = k - 1
          do while (j >= 1)
            if (snr(j) <= med) exit
            snr(j + 1) = snr(j)
            j = j - 1
          end do
          snr(j + 1) = med
        end do
        med = 0.5_wp*(snr((n + 1)/2) + snr(n/2 + 1))
      end if
      do k = 1, size(th)
        if (th(k) == 0.0_wp) then
          un(k) = 1.0_wp
          if (dg(k) > 0.0_wp) un(k) = med/sqrt(dg(k))
        end if
      end do
    end function search_units

    !> Newton iterations from res until converged or the iteration budget
    !> is spent, each trying the ranks rlo..rhi and keeping the best.
    subroutine iterate(rlo, rhi)
      integer, intent(in) :: rlo, rhi
      integer :: rank, rmax, rbest
      logical :: first
      first = .true.
      res%reason = STOP_NONE
      do while (it < opt%max_iter)
        it = it + 1
        ! the objective of this iteration: likelihood + prior term (weight s W)
        jnow = res%cost + prior_cost(res%theta, s)
        g = res%grad
        mt = res%info
        if (allocated(ex%weight)) then
          g = g + s*matmul(ex%weight, res%theta(pm%ifree) - ex%prior)
          mt = mt + s*ex%weight
        end if
        ! one eigen-decomposition per iteration serves every candidate rank
        call info_eig(mt, sc, w, v, status, msg)
        if (status == MLID_OK .and. rlo < nf) call info_eig(mt, scr, wr, vr, status, msg, unit)
        if (status /= MLID_OK) then
          res%reason = STOP_FAILED
          return
        end if
        call bounded_step(nf, step, decrement)
        if (status /= MLID_OK) then
          res%reason = STOP_FAILED
          return
        end if
        if (decrement <= opt%tol_grad) then
          res%reason = STOP_GRAD
          exit
        end if

        ! For each rank from rmin to full (block 7-10): the step, limited by the
        ! bounds (blocks 11-12), halved while the objective does not decrease;
        ! keep the best.
        ! ranks above the number of usable eigenvalues (ndrop from the full-rank
        ! step just taken) would repeat the same step
        rmax = min(nf - ndrop, rhi)
        jbest = huge(1.0_wp)
        best_step = 0.0_wp
        rbest = 0
        do rank = min(rlo, rmax), rmax
          call bounded_step(rank, step, decrement)
          if (status /= MLID_OK) then
            res%reason = STOP_FAILED
            return
          end if
          scale = 1.0_wp
          do ih = 0, opt%halvings
            trial = res%theta
            trial(pm%ifree) = trial(pm%ifree) + scale*step
            if (allocated(ex%lower)) &   ! no rounding across a bound
              trial(pm%ifree) = min(max(trial(pm%ifree), ex%lower), ex%upper)
            call apply_ties(pm%tie, trial)
            call likelihood(m, trial, pm, t, u, y, opt, jt, rt, yt, tstat, tmsg)
            if (tstat == MLID_OK .and. ieee_is_finite(jt)) then
              jt = jt + prior_cost(trial, s)
              ! ranks run upward: a higher rank must lower the cost by more than
              ! RANK_GAIN (a likelihood-ratio test per direction), or the weak
              ! directions stay where they are (report §5.3.6)
              if (rank > rbest .and. rbest > 0) then
                better = jt < jbest - RANK_GAIN
              else
                better = jt < jbest
              end if
              if (better) then
                jbest = jt
                best = trial
                best_step = scale*norm2(step)
                rbest = rank
              end if
              if (jt < jnow) exit
            end if
            scale = 0.5_wp*scale
          end do
        end do

        dj = jnow - jbest
        if (.not. (dj > 0.0_wp)) then
          ! No decrease: converged if the objective is flat to tolerance, else stuck.
          if (jbest < huge(1.0_wp) .and. abs(dj) <= opt%tol_cost*max(1.0_wp, abs(jnow))) then
            res%reason = STOP_COST
          else
            res%reason = STOP_NO_DECREASE
          end if
          exit
        end if

        res%niter = it
        if (first) res%rank = 0
        first = .false.
        res%rank = max(res%rank, rbest)   ! late steps are small in every direction
        res%theta = best
        call likelihood(m, res%theta, pm, t, u, y, opt, res%cost, res%rhat, res%yhat, &
                        status, msg, res%grad, res%info)
        if (status /= MLID_OK) then
          res%reason = STOP_FAILED
          return
        end if
        res%cost_hist(it + 1) = res%cost
        if (dj <= opt%tol_cost*max(1.0_wp, abs(jbest))) then
          res%reason = STOP_COST
          exit
        end if
        if (best_step <= opt%tol_step*norm2(res%theta(pm%ifree))) then
          res%reason = STOP_STEP
          exit
        end if
        s = s*opt%prior_decay
      end do
      if (res%reason == STOP_NONE) res%reason = STOP_MAXITER
      res%converged = any(res%reason == [STOP_COST, STOP_STEP, STOP_GRAD])
    end subroutine iterate

    !> 1/2 s (theta - prior)' W (theta - prior) over the free parameters.
    real(wp) function prior_cost(th, sw)
      real(wp), intent(in) :: th(:), sw
      real(wp) :: d(nf)
      prior_cost = 0.0_wp
      if (.not. allocated(ex%weight)) return
      d = th(pm%ifree) - ex%prior
      prior_cost = 0.5_wp*sw*dot_product(d, matmul(ex%weight, d))
    end function prior_cost

    !> The Newton step -M^-1 g of the given rank (and the Newton decrement
    !> sqrt(-g' step)), with the bounds of blocks 11-12: a parameter on a
    !> bound that the step would push outward is held there and the step
    !> solved again for the others; then the whole step is scaled so that no
    !> parameter crosses its bound.
    subroutine bounded_step(rank, st, dec)
      integer, intent(in) :: rank
      real(wp), intent(out) :: st(:), dec
      real(wp) :: th(nf), factor
      logical :: active(nf)
      integer :: k, nfree_act
      integer, allocatable :: keep(:)
      real(wp), allocatable :: sub(:, :), subw(:)

      if (rank < nf) then
        call eig_inverse(scr, wr, vr, opt%rcond, rank, cov, ndrop, res%bad_param)
      else
        call eig_inverse(sc, w, v, opt%rcond, rank, cov, ndrop, res%bad_param)
      end if
      st = -matmul(cov, g)
      if (allocated(ex%lower)) then
        th = res%theta(pm%ifree)
        active = (th <= ex%lower .and. st < 0.0_wp) .or. (th >= ex%upper .and. st > 0.0_wp)
        if (any(active)) then
          keep = pack([(k, k=1, nf)], .not. active)
          nfree_act = size(keep)
          allocate (sub(nfree_act, nfree_act), subw(nfree_act))
          st = 0.0_wp
          if (nfree_act > 0) then
            call info_inverse(mt(keep, keep), opt%rcond, sub, subw, ndrop, k, status, msg, &
                              min(rank, nfree_act))
            if (status /= MLID_OK) return
            st(keep) = -matmul(sub, g(keep))
          end if
        end if
        factor = 1.0_wp
        do k = 1, nf
          if (th(k) + st(k) > ex%upper(k)) factor = min(factor, (ex%upper(k) - th(k))/st(k))
          if (th(k) + st(k) < ex%lower(k)) factor = min(factor, (ex%lower(k) - th(k))/st(k))
        end do
        dec = sqrt(max(0.0_wp, -dot_product(g, st)))
        st = factor*st
      else
        dec = sqrt(max(0.0_wp, -dot_product(g, st)))
      end if
    end subroutine bounded_step

  end subroutine newton_fit

end module mlid_newton
