!> Modified Newton-Raphson (Gauss-Newton) maximisation of the likelihood,
!> report §4.3 and §4.6: step from the eigen-decomposition of the
!> information matrix (block 6), step halving when the cost rises (blocks
!> 8-9), stop on cost change, step size or gradient (§8.2.3).
module mlid_newton
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_SINGULAR, MLID_ERR_NOCONV, &
                        MLID_ERR_INPUT, MLID_ERR_INTERRUPTED, MLID_ERR_MEMORY, MLID_ERR_DIVERGED, &
                        STOP_NONE, STOP_COST, STOP_STEP, STOP_GRAD, STOP_MAXITER, &
                        STOP_NO_DECREASE, STOP_FAILED, STOP_DIVERGED
  use mlid_linalg, only: info_inverse, info_eig, eig_inverse
  use mlid_equation_error, only: equation_error
  use mlid_filter, only: oe_predict
  use mlid_models, only: model_t
  use mlid_options, only: options_t, METHOD_FILTER_ERROR
  use mlid_likelihood, only: likelihood, sens_keep_t
  use mlid_textbook_gain, only: textbook_t, textbook_gain
  use mlid_linalg, only: solve
  use mlid_params, only: param_map_t, apply_ties
  use mlid_text, only: itoa, es_text
  use mlid_interrupt, only: check_interrupt
  use mlid_memory, only: no_memory
  use mlid_progress, only: progress_t, progress_to
  implicit none
  private
  public :: fit_result_t, extras_t, newton_fit

  !> How much a higher rank must lower the cost (a negative log-likelihood)
  !> to be taken in the rank-deficient search: a likelihood-ratio test at 5%
  !> for one more direction, chi-square(1) 95% point 3.841 over 2.
  real(wp), parameter :: RANK_GAIN = 0.5_wp*3.841_wp
  !> The innovations criterion's least R(i,i), relative to the mean squared
  !> innovation of output i: a noise-free output's R stays regular.
  real(wp), parameter :: NOISE_FLOOR = 1.0e-6_wp
  !> A sane fit's R-hat(i,i), the mean squared residual (innovation) of
  !> output i, is at most this times the mean square of output i as
  !> measured: a residual 1000 times the measured signal in rms is a model
  !> that blew up, not one that fits (not_sane).
  real(wp), parameter :: SANE_RATIO = 1.0e6_wp
  !> The textbook criterion (FVSysID ml_fem2): R is re-estimated after the
  !> Newton step of this iteration and each later one (the early R of a poor
  !> start would mislead the gain), the F-compensation halved at most
  !> TEXTBOOK_HALVINGS times when it raises det R; R counts as settled when
  !> no R(i,i) moves by more than R_SETTLE_TOL of itself in the update.
  integer, parameter :: TEXTBOOK_R_FROM = 3, TEXTBOOK_HALVINGS = 2
  real(wp), parameter :: R_SETTLE_TOL = 1.0e-6_wp

  !> The estimator options of report §4.6 beyond plain Newton-Raphson, over
  !> the free parameters: a priori values and weight (block 7), bounds
  !> (blocks 11-12).  Unallocated: not used.
  type :: extras_t
    real(wp), allocatable :: prior(:)       !< a priori values (nf)
    real(wp), allocatable :: weight(:, :)   !< a priori weight matrix (nf, nf), positive semi-definite
    real(wp), allocatable :: lower(:), upper(:)   !< bounds (nf)
    !> the iterations taken, for a front end's progress (mlid_progress);
    !> not associated: not counted
    type(progress_t), pointer :: progress => null()
  end type extras_t

  !> What a search works on, fixed for its length: the model, the map of
  !> free parameters, the record, the options and the extras.
  type :: problem_t
    class(model_t), pointer :: m => null()
    type(param_map_t), pointer :: pm => null()
    real(wp), pointer :: t(:) => null(), u(:, :) => null(), y(:, :) => null()
    type(options_t), pointer :: opt => null()
    type(extras_t), pointer :: ex => null()
  end type problem_t

  !> What a Newton search carries from iteration to iteration.
  type :: search_t
    integer :: nf = 0                  !< free parameters
    integer :: it = 0                  !< iterations taken (all stages)
    integer :: ndrop = 0               !< eigenvalues dropped by the last step's inverse
    real(wp) :: s = 1.0_wp             !< weight of the prior term (decays each iteration)
    real(wp), allocatable :: unit(:)   !< units of the rank-deficient search
    real(wp), allocatable :: g(:), mt(:, :), cov(:, :)   !< gradient, information with the prior, step inverse
    real(wp), allocatable :: sc(:), w(:), v(:, :)        !< eigen-decomposition of mt
    real(wp), allocatable :: scr(:), wr(:), vr(:, :)     !< ... in the search's units
    logical :: deficient = .false.     !< scr, wr, vr hold this iteration's decomposition
  end type search_t

  !> The best trial point of one iteration over its ranks.
  type :: candidate_t
    real(wp) :: cost = huge(1.0_wp)    !< objective there (likelihood + prior term)
    real(wp), allocatable :: theta(:)
    real(wp) :: step = 0.0_wp          !< length of the step taken
    integer :: rank = 0                !< the rank that gave it (0: none)
  end type candidate_t

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
    !> what the weighted sensitivities at theta are made from (made once,
    !> for the bound corrected for coloured residuals)
    type(sens_keep_t), allocatable :: keep
    real(wp), allocatable :: msens(:, :)    !< the part of info they make
    real(wp), allocatable :: cov_c(:, :)    !< covariance corrected for coloured residuals
    !> innovations criterion: the innovation covariance averaged over the
    !> samples at theta (ny, ny); unallocated otherwise
    real(wp), allocatable :: bmean(:, :)
    integer, allocatable :: rmove(:)        !< ... and the sign of each r's last move there
    !> textbook criterion: diag(K C) of the gain at theta (nx; the constraint
    !> diag(KC) <= 1); unallocated otherwise
    real(wp), allocatable :: kc(:)
    character(len=256) :: note = ''         !< what a good fit should still say (a warning)
    integer :: lag = 0                      !< its residual-autocorrelation lag
    real(wp) :: cost = 0.0_wp               !< negative log-likelihood (without the prior term)
    integer :: niter = 0
    integer :: reason = STOP_NONE
    integer :: rank = 0                     !< highest rank of any step: the directions estimated
    integer :: bad_param = 0                !< free index dominating a singular direction
    logical :: converged = .false.
    logical :: started = .false.            !< the start was evaluated
    logical :: searched = .false.           !< the search ended (the final bound was made)
  end type fit_result_t

contains

  !> Maximise the likelihood over the free parameters of theta0 (map pm) on
  !> the record t, u, y as the method of opt sees it (the fit driver gives a
  !> frequency-domain method its transforms), with the options in ex: the
  !> start, the search, and the final Cramer-Rao bound.  On a non-zero
  !> status res still holds the last iterate; res%searched says whether the
  !> search ended (the final bound was made).
  subroutine newton_fit(m, theta0, pm, t, u, y, opt, ex, res, status, msg)
    class(model_t), intent(in), target :: m
    real(wp), intent(in) :: theta0(:)
    type(param_map_t), intent(in), target :: pm
    real(wp), intent(in), target :: t(:), u(:, :), y(:, :)
    type(options_t), intent(in), target :: opt
    type(extras_t), intent(in), target :: ex
    type(fit_result_t), intent(out) :: res
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(problem_t) :: pb
    type(search_t) :: st
    integer :: rmin, rtop, k
    real(wp) :: djr
    real(wp), allocatable :: th0(:)
    character(len=len(msg)) :: why

    pb = problem_t(m, pm, t, u, y, opt, ex)
    status = MLID_OK
    th0 = theta0
    if (opt%noise_criterion >= 1) call innovation_start(pb, status, msg)
    if (status == MLID_OK .and. opt%noise_criterion == 2) call textbook_start_r(pb, th0, status, msg)
    if (status /= MLID_OK) return
    call fit_start(pb, th0, res, status, msg)
    if (status == MLID_OK .and. opt%noise_criterion == 1) then
      call relax_noise(pb, res, djr, status, msg)     ! R from the start's innovations
      res%cost_hist(1) = res%cost
    end if
    if (status /= MLID_OK) return
    res%started = .true.
    st%nf = pm%nf
    allocate (st%g(st%nf), st%mt(st%nf, st%nf), st%cov(st%nf, st%nf), st%sc(st%nf), st%w(st%nf), &
              st%v(st%nf, st%nf), st%scr(st%nf), st%wr(st%nf), st%vr(st%nf, st%nf))
    rmin = st%nf
    if (opt%rank_min > 0) rmin = min(opt%rank_min, st%nf)
    rtop = st%nf
    if (opt%rank_max > 0) rtop = min(st%nf, opt%rank_max)
    st%unit = search_units(res%theta(pm%ifree), [(res%info(k, k), k=1, st%nf)])
    if (opt%rank_rule == 1 .and. rmin < rtop) then
      call staged_search(pb, st, res, rmin, rtop, status, msg)
    else
      call iterate(pb, st, res, min(rmin, rtop), rtop, status, msg)
    end if
    if (status /= MLID_OK) return
    res%converged = any(res%reason == [STOP_COST, STOP_STEP, STOP_GRAD])
    why = not_sane(res, y)
    if (len_trim(why) > 0) then      ! whatever test stopped it, it blew up
      res%reason = STOP_DIVERGED
      res%converged = .false.
    end if
    res%searched = .true.
    call final_bound(opt, ex, st, res, why, status, msg)
    if (opt%noise_criterion == 2) call gain_kc(pb, res)
  end subroutine newton_fit

  !> The textbook gain's diag(KC) at res%theta into res%kc (left
  !> unallocated if the gain cannot be had there).
  subroutine gain_kc(pb, res)
    type(problem_t), intent(in) :: pb
    type(fit_result_t), intent(inout) :: res
    type(textbook_t) :: tg
    integer :: tstat
    character(len=256) :: tmsg
    call textbook_gain(pb%m, res%theta, pb%pm, pb%t, pb%u, pb%opt, .false., tg, tstat, tmsg)
    if (tstat == MLID_OK) res%kc = tg%kc
  end subroutine gain_kc

  !> Why the fit res to the outputs y (as the search sees them) is not
  !> sane, '' when it is: its cost and every entry of R-hat must be finite,
  !> and no R-hat(i,i) above SANE_RATIO times the mean square of output i
  !> (an output measured as zero throughout gives no scale and is not
  !> checked).  Only a fit that blew up fails this: an unstable start on a
  !> long record can end a search on a point whose outputs dwarf the data,
  !> where the step test is met because the parameters hardly move.
  function not_sane(res, y) result(why)
    type(fit_result_t), intent(in) :: res
    real(wp), intent(in) :: y(:, :)
    character(len=256) :: why
    real(wp) :: ms
    integer :: i

    why = ''
    if (.not. (ieee_is_finite(res%cost) .and. all(ieee_is_finite(res%rhat)))) then
      why = 'diverged: the cost or R-hat is not finite'
      return
    end if
    do i = 1, size(res%rhat, 1)
      ms = sum(y(i, :)**2)/size(y, 2)
      if (.not. (ms > 0.0_wp .and. res%rhat(i, i) > SANE_RATIO*ms)) cycle
      why = 'diverged: R-hat('//itoa(i)//','//itoa(i)//') = '// &
            trim(adjustl(es_text(res%rhat(i, i), 9, 2)))//' is '// &
            trim(adjustl(es_text(res%rhat(i, i)/ms, 9, 2)))//' times the mean square of '// &
            'output '//itoa(i)//' (a sane fit''s is at most '// &
            trim(adjustl(es_text(SANE_RATIO, 9, 2)))//' times)'
      return
    end do
  end function not_sane

  !> The innovations criterion's start: r are not free (the relaxation
  !> estimates them); the first evaluation takes the given r.
  subroutine innovation_start(pb, status, msg)
    type(problem_t), intent(in) :: pb
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    status = MLID_OK
    msg = ''
    if (size(pb%pm%ir) > 0) then
      status = MLID_ERR_INPUT
      msg = 'r('//itoa(pb%pm%ir(1))//') is free, but with noise_criterion = '''// &
            trim(merge('innovations', 'textbook   ', pb%opt%noise_criterion == 1))//''' the '// &
            'r are estimated from the innovations after each step: leave them fixed'
    end if
  end subroutine innovation_start

  !> The textbook criterion's start R when no r is given (all zero): the
  !> mean squared output-error residuals at the start, no gain (ml_fem2's
  !> default, its iSD = 0); r given for some outputs only is refused.
  subroutine textbook_start_r(pb, theta, status, msg)
    type(problem_t), intent(in) :: pb
    real(wp), intent(inout) :: theta(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: yhat(:, :)
    integer :: i, ist
    integer, allocatable :: ir(:)
    status = MLID_OK
    msg = ''
    ir = [(pb%pm%l%or + i, i=1, pb%m%ny)]
    if (all(theta(ir) > 0.0_wp)) return
    if (any(theta(ir) /= 0.0_wp)) then
      status = MLID_ERR_INPUT
      msg = 'noise_criterion = ''textbook'': give r (the start R) for every output, or for none '// &
            '(R then starts at the output-error residuals'' mean squares, as ml_fem2 does)'
      return
    end if
    allocate (yhat(pb%m%ny, size(pb%t)), stat=ist)
    if (ist /= 0) then
      call no_memory('the output-error outputs at the start', real(pb%m%ny, wp)*size(pb%t), &
                     status, msg)
      return
    end if
    call oe_predict(pb%m, theta, pb%pm, pb%t, pb%u, pb%opt, yhat, status, msg)
    if (status /= MLID_OK) return
    theta(ir) = sum((pb%y - yhat)**2, dim=2)/size(pb%t)
  end subroutine textbook_start_r

  !> The relaxation's second half (innovations criterion, Maine and Iliff):
  !> after a Newton step on the other parameters, R becomes what the
  !> innovations leave for it, R(i,i) = S(i,i) - (C P C')(i,i) with S the
  !> mean squared innovations and C P C' = mean B - R, at least NOISE_FLOOR
  !> of S(i,i) (R >= 0 keeps the gain physical; the floor keeps B regular);
  !> an R that moves against its last move goes halfway (in ratio) only,
  !> which damps the two-cycle noise-free outputs otherwise fall into.
  !> The move is taken only where the likelihood falls: else it is halved
  !> in ratio, as a Newton step is, up to opt%halvings times, and then not
  !> taken (from a start where C P C' exceeds S the whole move takes R to
  !> its floor and the gain to the measurements: HFB-320, issue 44).
  !> djr: the cost's fall from it (>= 0).
  subroutine relax_noise(pb, res, djr, status, msg)
    type(problem_t), intent(in) :: pb
    type(fit_result_t), intent(inout) :: res
    real(wp), intent(out) :: djr
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: r0(pb%m%ny), target(pb%m%ny), j0
    integer :: i, ih, dir(pb%m%ny)
    integer, allocatable :: ir(:)

    djr = 0.0_wp
    associate (m => pb%m, pm => pb%pm)
      if (.not. allocated(res%rmove)) then
        allocate (res%rmove(m%ny))
        res%rmove = 0
      end if
      j0 = res%cost
      ir = [(pm%l%or + i, i=1, m%ny)]
      r0 = res%theta(ir)
      do i = 1, m%ny
        target(i) = max(res%rhat(i, i) - res%bmean(i, i) + r0(i), NOISE_FLOOR*res%rhat(i, i))
        dir(i) = int(sign(1.0_wp, target(i) - r0(i)))
        if (dir(i)*res%rmove(i) < 0) target(i) = sqrt(target(i)*r0(i))
      end do
      do ih = 0, pb%opt%halvings
        res%theta(ir) = target
        call evaluate_full(pb, res, status, msg)
        if (status == MLID_OK .and. res%cost <= j0) then
          res%rmove = dir
          djr = j0 - res%cost
          return
        end if
        if (status == MLID_ERR_INTERRUPTED) return
        target = sqrt(target*r0)
      end do
      res%theta(ir) = r0                     ! no move lowers the cost: R stays
      res%rmove = 0
      call evaluate_full(pb, res, status, msg)
      djr = 0.0_wp
    end associate
  end subroutine relax_noise

  !> Whether R is where the textbook criterion's update would leave it
  !> (within R_SETTLE_TOL); always for the other criteria.
  logical function r_settled(pb, res)
    type(problem_t), intent(in) :: pb
    type(fit_result_t), intent(in) :: res
    integer :: i
    r_settled = .true.
    if (pb%opt%noise_criterion /= 2) return
    do i = 1, pb%m%ny
      if (abs(res%rhat(i, i) - res%theta(pb%pm%l%or + i)) > R_SETTLE_TOL*res%theta(pb%pm%l%or + i)) &
        r_settled = .false.
    end do
  end function r_settled

  !> The textbook criterion's R update (FVSysID ml_fem2): r becomes the
  !> diagonal of the innovations' mean square, and the free q are rescaled
  !> for it (the F-compensation, textbook eq. 5.41): q_k times the mean of
  !> sqrt(R_new(i)/R_old(i)) over the outputs i weighted by (C Gamma)_ik^2
  !> / R_old(i) (squared for q a density), so that the gain changes little.
  !> Taken if det R does not rise; else the compensation is halved (q
  !> halfway back) up to TEXTBOOK_HALVINGS times, and then nothing moves.
  !> djr: the cost's fall from it (>= 0).
  subroutine textbook_noise(pb, res, djr, status, msg)
    type(problem_t), intent(in) :: pb
    type(fit_result_t), intent(inout) :: res
    real(wp), intent(out) :: djr
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(textbook_t) :: tg
    real(wp) :: r0(pb%m%ny), rn(pb%m%ny), q0(pb%m%nw), qn(pb%m%nw), w(pb%m%ny), ph, j0
    integer :: i, k, ih

    djr = 0.0_wp
    associate (m => pb%m, pm => pb%pm, l => pb%pm%l)
      call textbook_gain(m, res%theta, pm, pb%t, pb%u, pb%opt, .false., tg, status, msg)
      if (status /= MLID_OK) return
      j0 = res%cost
      r0 = res%theta(l%or + 1:l%or + m%ny)
      rn = [(res%rhat(i, i), i=1, m%ny)]
      q0 = res%theta(l%oq + 1:l%oq + m%nw)
      qn = q0
      do k = 1, size(pm%iq)
        i = pm%iq(k)
        w = tg%cg(:, i)**2/r0
        if (.not. sum(w) > 0.0_wp) cycle
        ph = sum(w*sqrt(rn/r0))/sum(w)
        qn(i) = q0(i)*merge(ph, ph**2, pb%opt%process_noise == 2)
      end do
      do ih = 0, TEXTBOOK_HALVINGS
        res%theta(l%or + 1:l%or + m%ny) = rn
        res%theta(l%oq + 1:l%oq + m%nw) = qn
        call apply_ties(pm%tie, res%theta)
        call evaluate_full(pb, res, status, msg)
        if (status == MLID_OK .and. res%cost <= j0) then
          djr = j0 - res%cost
          return
        end if
        if (status == MLID_ERR_INTERRUPTED) return
        qn = 0.5_wp*(qn + q0)
      end do
      res%theta(l%or + 1:l%or + m%ny) = r0     ! no update lowers det R: R and F stay
      res%theta(l%oq + 1:l%oq + m%nw) = q0
      call apply_ties(pm%tie, res%theta)
      call evaluate_full(pb, res, status, msg)
    end associate
  end subroutine textbook_noise

  !> The textbook criterion's inequality diag(KC) <= 1 on the Newton step
  !> (FVSysID's kcle1, textbook eqs 5.35-5.39), linearised about theta:
  !> kc + D step <= 1, D = d diag(KC)/dtheta.  The step minimising the
  !> Newton step's quadratic model 1/2 s' M s + g' s under them, by active
  !> sets: the violated constraints are held as equalities, s = s0 - cov
  !> D_a' lam with (D_a cov D_a') lam = kc_a + D_a s0 - 1 (cov = M^-1, s0 the
  !> free step); a constraint whose multiplier lam is negative is released,
  !> one the new step violates is added, until the set holds still.
  subroutine kc_constrain(pb, theta, cov, step, status, msg)
    type(problem_t), intent(in) :: pb
    real(wp), intent(in) :: theta(:), cov(:, :)
    real(wp), intent(inout) :: step(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(textbook_t) :: tg
    real(wp) :: s0(size(step))
    real(wp), allocatable :: lam(:)
    logical :: act(pb%m%nx), viol(pb%m%nx), movable(pb%m%nx)
    integer :: pass, ierr, k
    integer, allocatable :: ia(:)

    call textbook_gain(pb%m, theta, pb%pm, pb%t, pb%u, pb%opt, .true., tg, status, msg)
    if (status /= MLID_OK) return
    s0 = step
    act = .false.
    movable = any(tg%dkc /= 0.0_wp, dim=2)     ! a constraint no parameter moves is left alone
    do pass = 1, 4*pb%m%nx + 4
      if (any(act)) then
        ia = pack([(k, k=1, pb%m%nx)], act)
        call held(ia, step, lam, ierr)
        if (ierr /= 0) then                    ! dependent constraints: the free step stands
          step = s0
          return
        end if
        if (any(lam < 0.0_wp)) then            ! release the most negative multiplier
          act(ia(minloc(lam, 1))) = .false.
          step = s0
          cycle
        end if
      end if
      viol = .not. act .and. movable .and. tg%kc + matmul(tg%dkc, step) > 1.0_wp
      if (.not. any(viol)) exit
      act = act .or. viol
    end do

  contains

    !> The step with the constraints ia held as equalities, and their multipliers.
    subroutine held(ia, step, lam, ierr)
      integer, intent(in) :: ia(:)
      real(wp), intent(out) :: step(:)
      real(wp), allocatable, intent(out) :: lam(:)
      integer, intent(out) :: ierr
      real(wp) :: d(size(ia), size(step)), x(size(ia), 1)
      d = tg%dkc(ia, :)
      call solve(matmul(d, matmul(cov, transpose(d))), &
                 reshape(tg%kc(ia) + matmul(d, s0) - 1.0_wp, [size(ia), 1]), x, ierr)
      lam = x(:, 1)
      step = s0 - matmul(cov, matmul(transpose(d), lam))
    end subroutine held

  end subroutine kc_constrain

  !> The likelihood at res%theta with everything a Newton step needs.
  subroutine evaluate_full(pb, res, status, msg)
    type(problem_t), intent(in) :: pb
    type(fit_result_t), intent(inout) :: res
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    associate (m => pb%m, pm => pb%pm, t => pb%t, u => pb%u, y => pb%y, opt => pb%opt)
      if (opt%noise_criterion == 1) then
        if (.not. allocated(res%bmean)) allocate (res%bmean(m%ny, m%ny))
        call likelihood(m, res%theta, pm, t, u, y, opt, res%cost, res%rhat, res%yhat, status, &
                        msg, res%grad, res%info, msens=res%msens, bmean=res%bmean, &
                        keep=res%keep)
      else
        call likelihood(m, res%theta, pm, t, u, y, opt, res%cost, res%rhat, res%yhat, status, &
                        msg, res%grad, res%info, msens=res%msens, keep=res%keep)
      end if
    end associate
  end subroutine evaluate_full

  !> The start: res allocated, theta0 with its ties (or the equation-error
  !> start-up), and the likelihood there.
  subroutine fit_start(pb, theta0, res, status, msg)
    type(problem_t), intent(in) :: pb
    real(wp), intent(in) :: theta0(:)
    type(fit_result_t), intent(inout) :: res
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: ee_sigma(pb%pm%nf)
    integer :: nf, ny, nt, ist

    associate (m => pb%m, pm => pb%pm, t => pb%t, u => pb%u, y => pb%y, opt => pb%opt)
      nf = pm%nf
      ny = m%ny
      nt = size(t)
      allocate (res%grad(nf), res%info(nf, nf), res%cov(nf, nf), res%eigval(nf), &
                res%eigvec(nf, nf), res%rhat(ny, ny), res%yhat(ny, nt), &
                res%cost_hist(opt%max_iter + 1), res%keep, res%msens(nf, nf), stat=ist)
      if (ist /= 0) then
        call no_memory('the model outputs of '//itoa(nt)//' samples', real(ny, wp)*nt, &
          status, msg)
        return
      end if
      res%theta = theta0
      call apply_ties(pm%tie, res%theta)
      res%cost_hist = 0.0_wp
      res%rank = nf
      res%reason = STOP_FAILED
      if (opt%startup == 1) then
        call equation_error(m, theta0, pm, t, u, y, res%theta, ee_sigma, status, msg)
        if (status /= MLID_OK) return
      end if
      res%theta_start = res%theta
      call evaluate_full(pb, res, status, msg)
      if (status /= MLID_OK) return
      res%reason = STOP_NONE
      res%cost_hist(1) = res%cost
    end associate
  end subroutine fit_start

  !> Staged rank-deficient search: converge at the minimum rank, then free
  !> one more direction at a time and keep it only if the converged
  !> likelihood improves by more than RANK_GAIN; otherwise go back to the
  !> last accepted fit.
  subroutine staged_search(pb, st, res, rmin, rtop, status, msg)
    type(problem_t), intent(in) :: pb
    type(search_t), intent(inout) :: st
    type(fit_result_t), intent(inout) :: res
    integer, intent(in) :: rmin, rtop
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(fit_result_t) :: saved
    real(wp) :: jsaved
    integer :: rank

    associate (pm => pb%pm, ex => pb%ex)
      rank = rmin
      call iterate(pb, st, res, rank, rank, status, msg)
      do while (rank < rtop .and. status == MLID_OK .and. res%converged)
        saved = res
        jsaved = res%cost + prior_cost(ex, pm, res%theta, st%s)
        call iterate(pb, st, res, rank + 1, rank + 1, status, msg)
        if (status /= MLID_OK) return
        if (jsaved - (res%cost + prior_cost(ex, pm, res%theta, st%s)) <= RANK_GAIN) then
          res = saved
          exit
        end if
        rank = rank + 1
      end do
      res%rank = rank
    end associate
  end subroutine staged_search

  !> Newton iterations from res until converged or the iteration budget
  !> is spent, each trying the ranks rlo..rhi and keeping the best.
  subroutine iterate(pb, st, res, rlo, rhi, status, msg)
    type(problem_t), intent(in) :: pb
    type(search_t), intent(inout) :: st
    type(fit_result_t), intent(inout) :: res
    integer, intent(in) :: rlo, rhi
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(candidate_t) :: best
    type(fit_result_t) :: stash        ! the full evaluation of a first trial (best_of_ranks)
    real(wp) :: step(st%nf), decrement, jnow, dj, djr
    logical :: first, stashed, tb_stop

    associate (m => pb%m, pm => pb%pm, t => pb%t, u => pb%u, y => pb%y, opt => pb%opt, ex => pb%ex)
      first = .true.
      status = MLID_OK
      msg = ''
      res%reason = STOP_NONE
      do while (st%it < opt%max_iter)
        if (associated(ex%progress)) call progress_to(ex%progress, st%it)
        call check_interrupt(status, msg)
        if (status /= MLID_OK) then
          res%reason = STOP_FAILED
          return
        end if
        st%it = st%it + 1
        ! the objective of this iteration: likelihood + prior term (weight s W)
        jnow = res%cost + prior_cost(ex, pm, res%theta, st%s)
        call newton_system(pb, st, res, rlo < st%nf, status, msg)
        if (status == MLID_OK) call bounded_step(pb, st, res, st%nf, step, decrement, status, msg)
        if (status /= MLID_OK) then
          res%reason = STOP_FAILED
          return
        end if
        if (decrement <= opt%tol_grad .and. r_settled(pb, res)) then
          res%reason = STOP_GRAD
          exit
        end if
        ! ranks above the number of usable eigenvalues (ndrop from the full-rank
        ! step just taken) would repeat the same step
        call best_of_ranks(pb, st, res, rlo, min(st%nf - st%ndrop, rhi), jnow, best, status, &
                           msg, stash, stashed)
        if (status /= MLID_OK) then
          res%reason = STOP_FAILED
          return
        end if
        dj = jnow - best%cost
        ! the textbook criterion's stop (ml_fem2): once R is re-estimated, a
        ! step that changes det R by at most tol_cost of itself, before R moves
        tb_stop = opt%noise_criterion == 2 .and. st%it >= TEXTBOOK_R_FROM .and. &
                  flat(max(dj, 0.0_wp), jnow)
        if (.not. (dj > 0.0_wp) .and. tb_stop) then
          res%reason = STOP_COST
          exit
        end if
        if (.not. (dj > 0.0_wp)) then
          ! No decrease: converged if the objective is flat to tolerance, else stuck.
          if (best%cost < huge(1.0_wp) .and. flat(abs(dj), jnow)) then
            res%reason = STOP_COST
          else
            res%reason = STOP_NO_DECREASE
          end if
          exit
        end if
        res%niter = st%it
        if (first) res%rank = 0
        first = .false.
        res%rank = max(res%rank, best%rank)   ! late steps are small in every direction
        res%theta = best%theta
        if (stashed) then                  ! evaluated in full already: the same numbers
          stashed = all(stash%theta == best%theta)
        end if
        if (stashed) then
          call take_stash(stash, res)
        else
          call evaluate_full(pb, res, status, msg)
        end if
        djr = 0.0_wp
        if (status == MLID_OK .and. tb_stop) then
          res%cost_hist(st%it + 1) = res%cost
          res%reason = STOP_COST
          exit
        end if
        if (status == MLID_OK .and. opt%noise_criterion == 1) call relax_noise(pb, res, djr, status, msg)
        if (status == MLID_OK .and. opt%noise_criterion == 2 .and. st%it >= TEXTBOOK_R_FROM) &
          call textbook_noise(pb, res, djr, status, msg)
        if (status /= MLID_OK) then
          res%reason = STOP_FAILED
          return
        end if
        res%cost_hist(st%it + 1) = res%cost
        if (opt%noise_criterion /= 2 .and. &     ! (the textbook's stop is tb_stop's)
            max(dj, abs(djr)) <= opt%tol_cost*max(1.0_wp, abs(best%cost))) then
          res%reason = STOP_COST
          exit
        end if
        if (best%step <= opt%tol_step*norm2(res%theta(pm%ifree))) then
          res%reason = STOP_STEP
          exit
        end if
        st%s = st%s*opt%prior_decay
      end do
      if (res%reason == STOP_NONE) res%reason = STOP_MAXITER
      res%converged = any(res%reason == [STOP_COST, STOP_STEP, STOP_GRAD])
      if (associated(ex%progress)) call progress_to(ex%progress, st%it)
    end associate

  contains

    !> Whether a cost change dj (>= 0) from jref is within tol_cost: of
    !> max(1, |J|), or for the textbook criterion of det R (J = N/2 ln det R
    !> + const, so det R changes by the factor exp(2 dj / N)).
    logical function flat(dj, jref)
      real(wp), intent(in) :: dj, jref
      if (pb%opt%noise_criterion == 2) then
        flat = exp(2*dj/size(pb%t)) - 1.0_wp <= pb%opt%tol_cost
      else
        flat = dj <= pb%opt%tol_cost*max(1.0_wp, abs(jref))
      end if
    end function flat

  end subroutine iterate

  !> Gradient and information of this iteration's objective (with the
  !> prior term) and their eigen-decompositions: one per iteration serves
  !> every candidate rank (in the search's units only when a rank below
  !> full is tried).
  subroutine newton_system(pb, st, res, deficient, status, msg)
    type(problem_t), intent(in) :: pb
    type(search_t), intent(inout) :: st
    type(fit_result_t), intent(in) :: res
    logical, intent(in) :: deficient
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg

    associate (pm => pb%pm, ex => pb%ex)
      st%g = res%grad
      st%mt = res%info
      if (allocated(ex%weight)) then
        st%g = st%g + st%s*matmul(ex%weight, res%theta(pm%ifree) - ex%prior)
        st%mt = st%mt + st%s*ex%weight
      end if
      call info_eig(st%mt, st%sc, st%w, st%v, status, msg)
      if (status == MLID_OK .and. deficient) call info_eig(st%mt, st%scr, st%wr, st%vr, status, &
                                                          msg, st%unit)
      st%deficient = deficient
    end associate
  end subroutine newton_system

  !> For each rank from rlo to rmax (blocks 7-10): the step, limited by the
  !> bounds (blocks 11-12), halved while the objective does not decrease;
  !> the best of all.  Ranks run upward: a higher rank must lower the cost
  !> by more than RANK_GAIN (a likelihood-ratio test per direction), or the
  !> weak directions stay where they are (report §5.3.6).
  subroutine best_of_ranks(pb, st, res, rlo, rmax, jnow, best, status, msg, stash, stashed)
    type(problem_t), intent(in) :: pb
    real(wp), intent(in) :: jnow
    type(search_t), intent(inout) :: st
    type(fit_result_t), intent(inout) :: res
    integer, intent(in) :: rlo, rmax
    type(candidate_t), intent(out) :: best
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    !> Output error with one rank: the first trial is evaluated in full
    !> (sensitivities, information), so the accepted step, usually that one,
    !> needs no second integration; stashed says whether stash holds it.
    type(fit_result_t), intent(inout) :: stash
    logical, intent(out) :: stashed
    real(wp) :: step(st%nf), trial(size(res%theta)), decrement, scale, jt
    real(wp), allocatable :: rt(:, :), yt(:, :)   ! on the heap: worker threads have small stacks
    integer :: rank, ih, tstat
    logical :: better
    character(len=len(msg)) :: tmsg

    stashed = .false.
    associate (m => pb%m, pm => pb%pm, t => pb%t, u => pb%u, y => pb%y, opt => pb%opt, ex => pb%ex)
      allocate (rt(m%ny, m%ny), yt(m%ny, size(t)), stat=tstat)
      if (tstat /= 0) then
        call no_memory('a trial step of '//itoa(size(t))//' samples', &
          real(m%ny, wp)*size(t), status, msg)
        return
      end if
      best%cost = huge(1.0_wp)
      best%step = 0.0_wp
      best%rank = 0
      best%theta = res%theta
      do rank = min(rlo, rmax), rmax
        call bounded_step(pb, st, res, rank, step, decrement, status, msg)
        if (status /= MLID_OK) return
        scale = 1.0_wp
        do ih = 0, opt%halvings
          trial = res%theta
          trial(pm%ifree) = trial(pm%ifree) + scale*step
          if (allocated(ex%lower)) &   ! no rounding across a bound
            trial(pm%ifree) = min(max(trial(pm%ifree), ex%lower), ex%upper)
          call apply_ties(pm%tie, trial)
          if (ih == 0 .and. rlo >= rmax .and. opt%method /= METHOD_FILTER_ERROR) then
            if (.not. allocated(stash%keep)) then   ! (a copy of res would not check its memory)
              allocate (stash%rhat(m%ny, m%ny), stash%yhat(m%ny, size(t)), stash%grad(pm%nf), &
                        stash%info(pm%nf, pm%nf), stash%msens(pm%nf, pm%nf), stash%keep, &
                        stat=tstat)
              if (tstat /= 0) then
                call no_memory('a trial step of '//itoa(size(t))//' samples', &
                               real(m%ny, wp)*size(t), status, msg)
                return
              end if
            end if
            stash%theta = trial
            call likelihood(m, trial, pm, t, u, y, opt, stash%cost, stash%rhat, stash%yhat, &
                            tstat, tmsg, stash%grad, stash%info, msens=stash%msens, &
                            keep=stash%keep)
            jt = stash%cost
            stashed = tstat == MLID_OK
          else
            call likelihood(m, trial, pm, t, u, y, opt, jt, rt, yt, tstat, tmsg)
          end if
          if (tstat == MLID_ERR_INTERRUPTED .or. tstat == MLID_ERR_MEMORY) then
            status = tstat                   ! not a bad trial point: the fit ends
            msg = tmsg
            return
          end if
          if (tstat == MLID_OK .and. ieee_is_finite(jt)) then
            jt = jt + prior_cost(ex, pm, trial, st%s)
            if (rank > best%rank .and. best%rank > 0) then
              better = jt < best%cost - RANK_GAIN
            else
              better = jt < best%cost
            end if
            if (better) best = candidate_t(jt, trial, scale*norm2(step), rank)
            if (jt < jnow) exit
          end if
          scale = 0.5_wp*scale
        end do
      end do
    end associate
  end subroutine best_of_ranks

  !> The full evaluation best_of_ranks kept, as the iterate's: the large
  !> arrays swapped, not copied (the stash takes the old ones, of the same
  !> shapes, for the next trial to overwrite).
  subroutine take_stash(stash, res)
    type(fit_result_t), intent(inout) :: stash, res
    real(wp), allocatable :: y2(:, :)
    type(sens_keep_t), allocatable :: k
    res%cost = stash%cost
    res%rhat = stash%rhat
    res%grad = stash%grad
    res%info = stash%info
    res%msens = stash%msens
    call move_alloc(res%yhat, y2)
    call move_alloc(stash%yhat, res%yhat)
    call move_alloc(y2, stash%yhat)
    call move_alloc(res%keep, k)
    call move_alloc(stash%keep, res%keep)
    call move_alloc(k, stash%keep)
  end subroutine take_stash

  !> Cramer-Rao bound at the final estimate, with the prior's weight and
  !> the rank of the last step; a fit that diverged (why, from not_sane:
  !> the cause of the singular information it may bring), a singular
  !> information or an iteration that did not converge sets status (res is
  !> kept).
  subroutine final_bound(opt, ex, st, res, why, status, msg)
    type(options_t), intent(in) :: opt
    type(extras_t), intent(in) :: ex
    type(search_t), intent(inout) :: st
    type(fit_result_t), intent(inout) :: res
    character(len=*), intent(in) :: why
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: ndrop, k, tstat

    if (allocated(ex%weight)) res%info = res%info + st%s*ex%weight
    call info_inverse(res%info, opt%rcond, res%cov, res%eigval, ndrop, res%bad_param, status, &
                      msg, res%rank, res%eigvec)
    if (status /= MLID_OK .and. len_trim(why) > 0) then
      status = MLID_ERR_DIVERGED     ! a fit that blew up: why it is not sane, not the information
      msg = why
    end if
    if (status /= MLID_OK) return
    if (res%rank < st%nf) then   ! the covariance of the directions estimated, in the search's units
      call info_eig(res%info, st%scr, st%wr, st%vr, status, msg, st%unit)
      if (status /= MLID_OK) return
      call eig_inverse(st%scr, st%wr, st%vr, opt%rcond, res%rank, res%cov, k, tstat)
    end if
    if (len_trim(why) > 0) then
      status = MLID_ERR_NOCONV
      msg = why
    else if (ndrop > 0 .and. opt%rank_min == 0) then     ! singular, and no rank-deficient solution asked
      status = MLID_ERR_SINGULAR
      msg = 'information matrix singular ('//itoa(ndrop)//' eigenvalue(s) of the normalised '// &
            'matrix below '//trim(adjustl(es_text(opt%rcond, 9, 2)))//' of the largest): free '// &
            'parameter '//itoa(res%bad_param)//' is not identifiable from these data'
    else if (.not. res%converged) then
      status = MLID_ERR_NOCONV
      write (msg, '(a,i0,a)') 'not converged after ', res%niter, ' iterations: ' // &
        trim(merge('no cost decrease after all step halvings', &
                   'iteration limit reached                 ', &
                   res%reason == STOP_NO_DECREASE))
    end if
  end subroutine final_bound

  !> |theta_k|, or for a zero start value the marginal sigma 1/sqrt(M_kk)
  !> times the median |theta_j| sqrt(M_jj) of the others.  Units of the
  !> rank-deficient search: the step is then the least relative change, and
  !> a weak combination stays at its a priori value (§5.3.6); a parameter
  !> starting at zero is neither dropped nor favoured for that alone.
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

  !> 1/2 s (theta - prior)' W (theta - prior) over the free parameters.
  real(wp) function prior_cost(ex, pm, th, sw)
    type(extras_t), intent(in) :: ex
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: th(:), sw
    real(wp) :: d(pm%nf)
    prior_cost = 0.0_wp
    if (.not. allocated(ex%weight)) return
    d = th(pm%ifree) - ex%prior
    prior_cost = 0.5_wp*sw*dot_product(d, matmul(ex%weight, d))
  end function prior_cost

  !> The Newton step -M^-1 g of the given rank (and the Newton decrement
  !> sqrt(-g' step)), with the bounds of blocks 11-12: a parameter on a
  !> bound that the step would push outward is held there, one the step
  !> would carry across its bound goes to the bound exactly, and the step is
  !> solved again for the others, until none crosses.  (Scaling the whole
  !> step instead stalls a search whose parameter lies a rounding error off
  !> its bound: every step shrinks to nothing and looks converged.)
  subroutine bounded_step(pb, st, res, rank, step, dec, status, msg)
    type(problem_t), intent(in) :: pb
    type(search_t), intent(inout) :: st
    type(fit_result_t), intent(inout) :: res
    integer, intent(in) :: rank
    real(wp), intent(out) :: step(:), dec
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: th(st%nf), fixed(st%nf), factor
    logical :: active(st%nf), cross(st%nf)
    integer :: k, nf, pass

    associate (pm => pb%pm, opt => pb%opt, ex => pb%ex)
      nf = st%nf
      status = MLID_OK
      msg = ''
      ! a rank below nf in the search's units when a rank-deficient search
      ! runs; else only the singular directions are left out (rank nf - ndrop)
      if (rank < nf .and. st%deficient) then
        call eig_inverse(st%scr, st%wr, st%vr, opt%rcond, rank, st%cov, st%ndrop, res%bad_param)
      else
        call eig_inverse(st%sc, st%w, st%v, opt%rcond, rank, st%cov, st%ndrop, res%bad_param)
      end if
      step = -matmul(st%cov, st%g)
      if (allocated(ex%lower)) then
        th = res%theta(pm%ifree)
        fixed = 0.0_wp                 ! the step of a parameter held: to its bound
        active = (th <= ex%lower .and. step < 0.0_wp) .or. (th >= ex%upper .and. step > 0.0_wp)
        do pass = 1, nf
          if (any(active)) call held_step(active, fixed, rank, step, status, msg)
          if (status /= MLID_OK) return
          cross = .not. active .and. (th + step < ex%lower .or. th + step > ex%upper)
          if (.not. any(cross)) exit
          where (cross .and. th + step < ex%lower) fixed = ex%lower - th
          where (cross .and. th + step > ex%upper) fixed = ex%upper - th
          active = active .or. cross
        end do
        dec = sqrt(max(0.0_wp, -dot_product(st%g, step)))
        factor = 1.0_wp                ! a safeguard: the passes leave none across
        do k = 1, nf
          if (th(k) + step(k) > ex%upper(k)) factor = min(factor, (ex%upper(k) - th(k))/step(k))
          if (th(k) + step(k) < ex%lower(k)) factor = min(factor, (ex%lower(k) - th(k))/step(k))
        end do
        step = factor*step
      else
        dec = sqrt(max(0.0_wp, -dot_product(st%g, step)))
      end if
      if (opt%noise_criterion == 2) then   ! the step within diag(KC) <= 1
        call kc_constrain(pb, res%theta, st%cov, step, status, msg)
        ! a constrained step need not descend: its length in sigmas instead
        dec = sqrt(max(0.0_wp, dot_product(step, matmul(st%mt, step))))
      end if
    end associate

  contains

    !> The step with the active parameters' steps fixed: the others minimise
    !> the quadratic model, M_kk s_k = -(g_k + M_ka s_a).
    subroutine held_step(active, fixed, rank, step, status, msg)
      logical, intent(in) :: active(:)
      real(wp), intent(in) :: fixed(:)
      integer, intent(in) :: rank
      real(wp), intent(out) :: step(:)
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
      integer, allocatable :: keep(:), act(:)
      real(wp), allocatable :: sub(:, :), subw(:)
      integer :: n, j
      keep = pack([(j, j=1, size(active))], .not. active)
      act = pack([(j, j=1, size(active))], active)
      n = size(keep)
      status = MLID_OK
      msg = ''
      step = 0.0_wp
      step(act) = fixed(act)
      if (n == 0) return
      allocate (sub(n, n), subw(n))
      call info_inverse(st%mt(keep, keep), pb%opt%rcond, sub, subw, st%ndrop, j, status, msg, &
                        min(rank, n))
      if (status /= MLID_OK) return
      step(keep) = -matmul(sub, st%g(keep) + matmul(st%mt(keep, act), fixed(act)))
    end subroutine held_step

  end subroutine bounded_step

end module mlid_newton
