!> The negative log-likelihood (report eq. 4.17), its gradient (4.30) and
!> information matrix (4.37), for the two estimators:
!>
!> output error (§4.4): innovations are output errors; R is estimated from
!>   the residuals, R = (1/N) sum nu nu' (its diagonal, or all of it).  The
!>   gradient and information are taken with R held at that estimate; at
!>   R-hat the gradient equals that of the concentrated cost, so one Newton
!>   step on theta and one re-estimate of R make a consistent relaxation.
!> filter error (§4.1, §4.3): innovations and their covariances B(j) from the
!>   Kalman filter; R, Q and S are parameters like any other.
!>
!>     J = 1/2 sum_j [ nu_j' B_j^-1 nu_j + ln|B_j| ]
!>     M_kl = sum_j [ dnu_k' B^-1 dnu_l + 1/2 tr(B^-1 dB_k B^-1 dB_l) ]
!>
!>   The time-varying filter starts each manoeuvre from P(1|0) = diag(p0)
!>   (zero by default: a known initial state).
!> filter error with K and B as the parameters (opt%filter_params, report
!>   eqs 4.19-4.21): the gain K (block stab) is a parameter like F and G, the
!>   predictor is the stabilized output error's, and B is estimated from the
!>   innovations as output error estimates R (eq. 4.20); the constraints that
!>   tie K and B to some Q and R (eqs 4.9, 4.15-4.18) are not imposed, as the
!>   report has it.
!>   A nonlinear model's extended Kalman filter takes dnu and dB with the
!>   gain partials (opt%partials) from forward differences of whole filter
!>   runs: its gain depends on the parameters also through the
!>   linearisation, whose analytic partials would need second derivatives
!>   of f and h.  Without partials the analytic sensitivities hold the gain.
!> filter error as the textbook computes it (noise_criterion = 'textbook',
!>   FVSysID's ml_fem2): the gain K(theta) of the continuous Riccati equation
!>   with R dt as the measurement density (mlid_textbook_gain; R = diag(r),
!>   held), the predictor x(j|j) = x(j|j-1) + K nu(j) as the stabilized
!>   output error's, R-hat = diag of the mean squared innovations and the
!>   cost 1/2 N (ny + ln det R-hat): det R as the textbook's cost.  The
!>   sensitivities carry dK/dtheta (analytic) as a free K's would, each
!>   parameter moving K's entries by its partials.
module mlid_likelihood
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_SINGULAR, MLID_ERR_INPUT, MLID_ERR_DIVERGED, &
                        first_failure
  use mlid_linalg, only: add_syrk, add_atv, add_sym_atb, sym_atb_t, pair_rows, chol_inverse, &
                         psd_factor
  use mlid_models, only: model_t
  use mlid_options, only: options_t, frequency_method, METHOD_FILTER_ERROR
  use mlid_frequency, only: freq_likelihood
  use mlid_params, only: param_map_t, apply_ties, input_delays, output_delays, stabilized
  use mlid_filter, only: oe_predict, kf_innovations
  use mlid_textbook_gain, only: textbook_t, textbook_gain
  use mlid_memory, only: no_memory
  use mlid_text, only: itoa, es_text
  implicit none
  private
  public :: likelihood, sens_keep_t, weighted_sensitivities

  !> What the weighted sensitivities (wsens: W(j) dyhat/dtheta, for the
  !> coloured-residual correction, mlid_colored) are made from, kept from a
  !> full evaluation: the sensitivities and their weights come with every
  !> evaluation anyway, and a fit weighs them once, at its estimate
  !> (weighted_sensitivities), not at every evaluation.
  type :: sens_keep_t
    !> output error: the output sensitivities (ny, nf, nt); filter error:
    !> the innovations'
    real(wp), allocatable :: dy(:, :, :)
    !> the weights: output error R^-1 (ny, ny, 1), filter error B(j)^-1
    !> (ny, ny, nt; the steady-state filter's one B^-1: (ny, ny, 1))
    real(wp), allocatable :: w(:, :, :)
    logical :: filter = .false.   !< filter error's weights, one per sample
    logical :: full_r = .false.   !< output error with the full R (else its diagonal)
  end type sens_keep_t

  !> Blocks of samples summed in order in the filter-error gradient and
  !> information, whatever the number of threads.
  integer, parameter :: NBLOCK = 64
  !> Samples a block of the output-error information takes: its weighted
  !> sensitivities (7 outputs, 11 parameters: 39 kB) stay in the cache.
  integer, parameter :: SAMPLE_BLOCK = 64

contains

  !> Cost at theta (and gradient and information for the free parameters
  !> when grad and info are present) by the method of opt.  rhat receives
  !> R-hat (output error) or the mean innovation covariance (filter error).
  subroutine likelihood(m, theta, pm, t, u, y, opt, cost, rhat, yhat, status, msg, grad, info, &
                        sens, msens, bmean, keep)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: cost, rhat(:, :), yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out), optional :: grad(:), info(:, :)
    !> output sensitivity norms (ny, nf): sqrt(sum_t (d yhat_i/d theta_k)^2 / R_ii),
    !> how many residual sigmas parameter k moves output i over the record
    !> (innovations for filter error); needs grad and info
    real(wp), intent(out), optional :: sens(:, :)
    !> for the coloured-residual correction (mlid_colored), with grad and
    !> info: the part of info the sensitivities make, sum_j S(j)' W(j) S(j)
    !> (nf, nf)
    real(wp), intent(out), optional :: msens(:, :)
    !> filter error: the innovation covariance B(j) = C P(j) C' + R averaged
    !> over the samples (ny, ny), for the innovations criterion (mlid_newton)
    real(wp), intent(out), optional :: bmean(:, :)
    !> with grad and info (time domain): what the weighted sensitivities
    !> W(j) dyhat/dtheta are made from (weighted_sensitivities), for a fit
    !> to weigh once at its estimate (its arrays are reused when they fit)
    type(sens_keep_t), intent(inout), optional :: keep

    cost = huge(1.0_wp)
    call filter_check(theta, pm, opt, status, msg)
    if (status /= MLID_OK) return
    if (frequency_method(opt)) then      ! t, u, y are the transformed record
      call freq_likelihood(m, theta, pm, t, u, y, opt, cost, rhat, yhat, status, msg, grad, &
                           info, sens, msens)
    else if (opt%method == METHOD_FILTER_ERROR .and. opt%noise_criterion == 2) then
      call textbook_likelihood(m, theta, pm, t, u, y, opt, cost, rhat, yhat, status, msg, grad, &
                               info, sens, msens, keep)
    else if (opt%method == METHOD_FILTER_ERROR .and. opt%filter_params == 1) then
      ! K and B as the parameters: the predictor with the gain K, B = R-hat
      call oe_likelihood(m, theta, pm, t, u, y, opt, cost, rhat, yhat, status, msg, grad, info, &
                         sens, msens, keep)
    else if (opt%method == METHOD_FILTER_ERROR .and. (output_delays(theta, pm) .or. &
                                                   input_delays(theta, pm))) then
      status = MLID_ERR_INPUT
      msg = 'time delays are for output error (method = ''output_error''), not the filter'
      return
    else if (opt%method == METHOD_FILTER_ERROR .and. stabilized(theta, pm%l)) then
      status = MLID_ERR_INPUT
      msg = 'stab, the gain of the stabilized output error, is for output error; the filter '// &
            'has its own'
      return
    else if (size(pm%iu) > 0 .and. .not. m%has_input_jacobians()) then
      status = MLID_ERR_INPUT
      msg = 'a free input time delay needs the model''s input Jacobians: kinds linear, '// &
            'equations, sixdof, flight_path'
      return
    else if (opt%method == METHOD_FILTER_ERROR) then
      call fe_likelihood(m, theta, pm, t, u, y, opt, cost, rhat, yhat, status, msg, grad, info, &
                         sens, msens, bmean, keep)
    else
      call oe_likelihood(m, theta, pm, t, u, y, opt, cost, rhat, yhat, status, msg, grad, info, &
                         sens, msens, keep)
    end if
    if (status == MLID_OK .and. .not. ieee_is_finite(cost)) then
      status = MLID_ERR_SINGULAR
      msg = 'cost is not finite'
    end if
  end subroutine likelihood

  !> What each estimator does not take: a free gain K (block stab) but with
  !> filter_params = 'gain'; then no free noise statistics; an initial
  !> covariance p0 but for the time-varying Kalman filter.
  subroutine filter_check(theta, pm, opt, status, msg)
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    type(options_t), intent(in) :: opt
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    logical :: gain, p0
    gain = opt%method == METHOD_FILTER_ERROR .and. opt%filter_params == 1
    p0 = size(pm%ip0) > 0 .or. any(theta(pm%l%op0 + 1:pm%l%nth) /= 0.0_wp)
    status = MLID_ERR_INPUT
    if (size(pm%ik) > 0 .and. .not. gain) then
      msg = 'stab, the gain of the stabilized output error, is a setting: free only as the '// &
            'filter''s gain K, with method = ''filter_error'' and filter_params = ''gain'' '// &
            '(report eqs 4.19-4.21)'
    else if (gain .and. size([pm%iq, pm%ir, pm%is]) > 0) then
      msg = 'with filter_params = ''gain'' the gain K (stab) and B replace q, r and s: '// &
            'leave those fixed'
    else if (p0 .and. (opt%method /= METHOD_FILTER_ERROR .or. gain .or. opt%steady)) then
      msg = 'p0, the initial state covariance, is the time-varying Kalman filter''s '// &
            '(method = ''filter_error'', steady_state = false, filter_params = ''noise'')'
    else if (any(theta(pm%l%op0 + 1:pm%l%nth) < 0.0_wp)) then
      msg = 'the initial state covariance p0 must be >= 0'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine filter_check

  !> The textbook criterion: output error's likelihood of the predictor
  !> with the gain K(theta) (block stab set to it), the free columns moving
  !> K's entries by dK/dtheta (the map's gain entries: entry, column,
  !> weight), so that the sensitivities are those of the whole predictor.
  subroutine textbook_likelihood(m, theta, pm, t, u, y, opt, cost, rhat, yhat, status, msg, &
                                 grad, info, sens, msens, keep)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: cost, rhat(:, :), yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out), optional :: grad(:), info(:, :), sens(:, :), msens(:, :)
    type(sens_keep_t), intent(inout), optional :: keep
    type(textbook_t) :: tg
    type(param_map_t) :: pk
    real(wp), allocatable :: th(:), dk(:, :)
    integer :: e, c, n, nk

    cost = huge(1.0_wp)
    status = MLID_ERR_INPUT
    if (output_delays(theta, pm) .or. input_delays(theta, pm)) then
      msg = 'time delays are for output error (method = ''output_error''), not the filter'
      return
    else if (stabilized(theta, pm%l)) then
      msg = 'stab, the gain of the stabilized output error, is for output error; the filter '// &
            'has its own'
      return
    else if (size(pm%ir) > 0) then
      msg = 'r('//itoa(pm%ir(1))//') is free, but with noise_criterion = ''textbook'' the r are '// &
            'the innovations'' mean squares, set after each step: leave them fixed'
      return
    else if (size(pm%is) > 0 .or. any(theta(pm%l%os + 1:pm%l%os + m%nw*m%ny) /= 0.0_wp)) then
      msg = 'noise_criterion = ''textbook'' has no cross-covariance s of process and '// &
            'measurement noise: leave s at zero'
      return
    end if
    call textbook_gain(m, theta, pm, t, u, opt, present(grad), tg, status, msg)
    if (status /= MLID_OK) return
    nk = m%nx*m%ny
    th = theta
    th(pm%l%ostab + 1:pm%l%ostab + nk) = reshape(tg%k, [nk])
    pk = pm
    if (present(grad)) then
      dk = reshape(tg%dk, [nk, pm%nf])
      n = count(dk /= 0.0_wp)
      deallocate (pk%ik, pk%ck, pk%wk)
      allocate (pk%ik(n), pk%ck(n), pk%wk(n), stat=e)
      if (e /= 0) then
        call no_memory('the gain''s partials', 3.0_wp*n, status, msg)
        return
      end if
      n = 0
      do c = 1, pm%nf
        do e = 1, nk
          if (dk(e, c) == 0.0_wp) cycle
          n = n + 1
          pk%ik(n) = e
          pk%ck(n) = c
          pk%wk(n) = dk(e, c)
        end do
      end do
    end if
    call oe_likelihood(m, th, pk, t, u, y, opt, cost, rhat, yhat, status, msg, grad, info, &
                       sens, msens, keep, theta(pm%l%or + 1:pm%l%or + m%ny))
    if (status == MLID_ERR_DIVERGED .and. maxval(tg%kc) > 1.0_wp) &   ! why, most likely
      msg = trim(msg)//'; the textbook gain has diag(KC) up to '// &
            trim(adjustl(es_text(maxval(tg%kc), 9, 2)))//' > 1 here: start with r larger '// &
            '(the textbook''s: the output-error residual variances)'
  end subroutine textbook_likelihood

  subroutine oe_likelihood(m, theta, pm, t, u, y, opt, cost, rhat, yhat, status, msg, grad, &
                           info, sens, msens, keep, rgain)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: cost, rhat(:, :), yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out), optional :: grad(:), info(:, :), sens(:, :), msens(:, :)
    type(sens_keep_t), intent(inout), optional :: keep
    !> the textbook criterion: the gradient and information weighted by this
    !> R (the gain's, diagonal) instead of R-hat, as the textbook's
    !> Gauss-Newton step has them (the same at its fixed point R = R-hat)
    real(wp), intent(in), optional :: rgain(:)
    real(wp), allocatable :: dy(:, :, :), nu(:, :), w1(:, :, :)
    real(wp) :: rinv(m%ny, m%ny), logdet, lw(m%ny, m%ny), rdiag(m%ny)
    real(wp), allocatable :: gpart(:, :), ipart(:, :, :)
    integer :: ny, nt, nf, i, k, ierr, ist
    logical :: ok

    ny = m%ny
    nt = size(t)
    nf = pm%nf
    allocate (nu(ny, nt), stat=ist)
    if (ist /= 0) then
      call no_memory('the residuals of '//itoa(nt)//' samples', real(ny, wp)*nt, status, msg)
      return
    end if
    if (present(grad)) then
      if (present(keep)) call reuse(keep%dy, [ny, nf, nt], dy)
      ist = 0
      if (.not. allocated(dy)) allocate (dy(ny, nf, nt), stat=ist)
      if (ist /= 0) then
        call no_memory(sens_text(nt, nf), real(ny, wp)*nf*nt, status, msg)
        return
      end if
      call oe_predict(m, theta, pm, t, u, opt, yhat, status, msg, dy=dy, z=y)
    else
      call oe_predict(m, theta, pm, t, u, opt, yhat, status, msg, z=y)
    end if
    if (status /= MLID_OK) return

    nu(:, :) = y - yhat
    if (opt%full_r) then
      rhat = matmul(nu, transpose(nu))/nt
    else                                    ! the diagonal only
      rhat = 0.0_wp
      do i = 1, ny
        rhat(i, i) = sum(nu(i, :)**2)/nt
      end do
    end if
    do i = 1, ny
      if (.not. (rhat(i, i) > tiny(1.0_wp))) then
        status = MLID_ERR_SINGULAR
        write (msg, '(a,i0,a)') 'residual variance of output ', i, &
          ' is zero, below the smallest normal number or not finite: the output is fitted '// &
          'exactly (noise-free or constant data?), or its units make it too small (scale it)'
        return
      end if
    end do
    call chol_inverse(rhat, rinv, logdet, ierr)
    if (ierr /= 0) then
      status = MLID_ERR_SINGULAR
      msg = 'residual covariance is singular (outputs linearly dependent): use noise = ''diagonal'''
      return
    end if
    do i = 1, ny
      rdiag(i) = rinv(i, i)
    end do
    if (diagonal(rinv)) then     ! R^-1 nu by rows: matmul's sums, whose other terms are zeros
      cost = 0.0_wp
      do k = 1, nt                 ! in sum's order
        do i = 1, ny
          cost = cost + nu(i, k)*(rdiag(i)*nu(i, k))
        end do
      end do
      cost = 0.5_wp*(cost + nt*logdet)
    else
      cost = 0.5_wp*(sum(nu*matmul(rinv, nu)) + nt*logdet)
    end if

    if (present(grad) .and. present(info)) then
      ! segments in parallel, their parts added in order: the result does
      ! not depend on the number of threads
      ! the weights: R^-1 = L L' (L = diag(sqrt(1/R_ii)) for a diagonal R)
      if (present(rgain)) then
        rinv = 0.0_wp
        do i = 1, ny
          rinv(i, i) = 1.0_wp/rgain(i)
        end do
      end if
      call psd_factor(rinv, lw, ok)
      allocate (gpart(nf, pm%l%nseg), ipart(nf, nf, pm%l%nseg))
      !$omp parallel do schedule(dynamic, 1) if (pm%l%nseg > 1)
      do k = 1, pm%l%nseg
        call segment_information(k, gpart(:, k), ipart(:, :, k))
      end do
      !$omp end parallel do
      grad = 0.0_wp
      info = 0.0_wp
      do k = 1, pm%l%nseg
        grad = grad + gpart(:, k)
        info = info + ipart(:, :, k)
      end do
      if (present(msens)) msens = info
      if (present(sens)) call sensitivity_norms(dy, rhat, sens)
      if (present(keep)) then
        call move_alloc(dy, keep%dy)
        call reuse(keep%w, [ny, ny, 1], w1)
        if (.not. allocated(w1)) allocate (w1(ny, ny, 1))
        w1(:, :, 1) = rinv
        call move_alloc(w1, keep%w)
        keep%filter = .false.
        keep%full_r = opt%full_r
      end if
    end if

  contains

    !> Segment iseg's part of grad and info, over the columns that move in
    !> it only (a bias of another manoeuvre adds zeros).  With R^-1 = L L', the weighted sensitivities w = L' dy/dtheta
    !> give the information as the sum of w_i' w_i over the weighted outputs
    !> i and the gradient as -w_i' (L' nu)_i: each output's over the columns
    !> that move it only (an output's own bias, a coefficient of one output
    !> equation: most columns touch few outputs), a block of samples at a
    !> time, the output's residual as the last column of the same
    !> symmetric product (sym_atb_t: samples across, columns down).
    subroutine segment_information(iseg, g, f)
      integer, intent(in) :: iseg
      real(wp), intent(out) :: g(:), f(:, :)
      real(wp), allocatable :: wt(:), part(:)
      integer, allocatable :: cols(:), rows(:), ci(:), first(:), nci(:), pw(:), pp(:)
      integer(int64), allocatable :: src(:)
      integer :: j0, j1, jbeg, jend, c, i, r, q, ld
      logical :: moves(ny, nf)
      jbeg = pm%l%seg(iseg)
      jend = nt
      if (iseg < pm%l%nseg) jend = pm%l%seg(iseg + 1) - 1
      call moving_outputs(ny, nf, jend - jbeg + 1, dy(:, :, jbeg:jend), moves)
      cols = pack([(c, c=1, nf)], any(moves, dim=1))
      g = 0.0_wp
      f = 0.0_wp
      ! weighted output i's columns ci(first(i):first(i)+nci(i)-1): those
      ! moving an output r that L(r, i) weighs in (a diagonal R: output i)
      allocate (first(ny), nci(ny), ci(0))
      do i = 1, ny
        first(i) = size(ci) + 1
        rows = [i]
        if (opt%full_r) rows = pack([(r, r=1, ny)], lw(:, i) /= 0.0_wp)
        ci = [ci, pack(cols, [(any(moves(rows, cols(q))), q=1, size(cols))])]
        nci(i) = size(ci) - first(i) + 1
      end do
      if (size(ci) == ny*size(cols)) then             ! every column moves every output
        call stacked_outputs(cols, jbeg, jend, g, f)
        return
      end if
      ! output i's block of weighted sensitivities at wt(pw(i)+1) (an odd
      ! column count's padding row zeroed once here), its product at part(pp(i)+1)
      allocate (pw(ny + 1), pp(ny + 1))
      pw(1) = 0
      pp(1) = 0
      do i = 1, ny
        pw(i + 1) = pw(i) + pair_rows(nci(i) + 1)*SAMPLE_BLOCK
        pp(i + 1) = pp(i) + (nci(i) + 1)**2
      end do
      ! src: one entry past the last, so that src(first(i)) of an output
      ! with no moving columns (nci(i) = 0, nothing read) is inside it
      allocate (wt(pw(ny + 1)), part(pp(ny + 1)), src(size(ci) + 1))
      do i = 1, ny                  ! weigh_diagonal's offsets of output i's entries
        do q = first(i), first(i) + nci(i) - 1
          src(q) = i + ny*(ci(q) - 1)
        end do
      end do
      wt = 0.0_wp
      part = 0.0_wp
      do j0 = jbeg, jend, SAMPLE_BLOCK
        j1 = min(jend, j0 + SAMPLE_BLOCK - 1)
        do i = 1, ny
          ld = pair_rows(nci(i) + 1)
          associate (cc => ci(first(i):first(i) + nci(i) - 1))
            if (count(lw(:, i) /= 0.0_wp) > 1) then
              call weigh_output(i, ny, nf, j1 - j0 + 1, nci(i), cc, lw, dy(:, :, j0:j1), &
                                nu(:, j0:j1), ld, wt(pw(i) + 1))
            else
              call weigh_diagonal(i, ny, nf, j1 - j0 + 1, nci(i), src(first(i)), lw(i, i), &
                                  dy(:, :, j0:j1), nu(:, j0:j1), ld, wt(pw(i) + 1))
            end if
          end associate
          call sym_atb_t(j1 - j0 + 1, ld, nci(i) + 1, wt(pw(i) + 1), wt(pw(i) + 1), &
                         part(pp(i) + 1))
        end do
      end do
      do i = 1, ny
        call add_output(ci(first(i):first(i) + nci(i) - 1), part(pp(i) + 1), g, f)
      end do
    end subroutine segment_information

    !> segment_information's sums when every column moves every output: the
    !> outputs of a block of samples stacked (samples and outputs down, the
    !> columns across, L' nu the last: one product, without the per-output
    !> tiles' padding), the gradient as -w' (L' nu).
    subroutine stacked_outputs(cols, jbeg, jend, g, f)
      integer, intent(in) :: cols(:), jbeg, jend
      real(wp), intent(inout) :: g(:), f(:, :)
      real(wp), allocatable :: w(:, :), part(:, :)
      integer :: j0, j1, nc
      nc = size(cols)
      allocate (w(ny*SAMPLE_BLOCK, nc + 1), part(nc + 1, nc + 1))
      part = 0.0_wp
      do j0 = jbeg, jend, SAMPLE_BLOCK
        j1 = min(jend, j0 + SAMPLE_BLOCK - 1)
        call weigh_block(opt%full_r, ny, nf, j0, j1, nc, cols, lw, dy(:, :, j0:j1), &
                         nu(:, j0:j1), w)
        call add_syrk(ny*(j1 - j0 + 1), nc + 1, w, part)
      end do
      g(cols) = -part(1:nc, nc + 1)
      f(cols, cols) = part(1:nc, 1:nc)
    end subroutine stacked_outputs

  end subroutine oe_likelihood

  !> Whether a is diagonal (every entry off the diagonal zero).
  pure logical function diagonal(a)
    real(wp), intent(in) :: a(:, :)
    integer :: i, j
    diagonal = .false.
    do j = 1, size(a, 2)
      do i = 1, size(a, 1)
        if (i /= j .and. a(i, j) /= 0.0_wp) return
      end do
    end do
    diagonal = .true.
  end function diagonal

  !> moves(i, c): whether any of the n samples' dy(i, c, j) is not zero,
  !> exactly (however small).  A column that moves an output mostly shows
  !> it at once; the others are read to the end, four samples a test (a
  !> sum of magnitudes is zero only when each is; NaN is not zero).
  pure subroutine moving_outputs(ny, nf, n, dy, moves)
    integer, intent(in) :: ny, nf, n
    real(wp), intent(in) :: dy(ny, nf, n)
    logical, intent(out) :: moves(ny, nf)
    integer :: i, c, j
    do c = 1, nf
      outputs: do i = 1, ny
        moves(i, c) = .true.
        do j = 1, n - 3, 4
          if (abs(dy(i, c, j)) + abs(dy(i, c, j + 1)) + abs(dy(i, c, j + 2)) &
              + abs(dy(i, c, j + 3)) /= 0.0_wp) cycle outputs
        end do
        do j = n - mod(n, 4) + 1, n
          if (dy(i, c, j) /= 0.0_wp) cycle outputs
        end do
        moves(i, c) = .false.
      end do outputs
    end do
  end subroutine moving_outputs

  !> wsens(i, jbeg:jend, c) = 0 where column c leaves output i unmoved (no
  !> sensitivity there; the rest is written with the products).
  subroutine zero_unmoved(ny, nf, nt, jbeg, jend, moves, wsens)
    integer, intent(in) :: ny, nf, nt, jbeg, jend
    logical, intent(in) :: moves(ny, nf)
    real(wp), intent(inout) :: wsens(ny, nt, nf)
    integer :: c, i, j
    do c = 1, nf
      do i = 1, ny
        if (moves(i, c)) cycle
        !GCC$ unroll 4
        do j = jbeg, jend
          wsens(i, j, c) = 0.0_wp
        end do
      end do
    end do
  end subroutine zero_unmoved

  !> The weighted sensitivities w(:, j, c) = L' dy(:, cols(c), j) of the
  !> block of samples j0..j1 (dy and nu: the block's), samples and outputs
  !> down the rows of w, and w(:, j, nc+1) = L' nu(:, j).
  subroutine weigh_block(full, ny, nf, j0, j1, nc, cols, lw, dy, nu, w)
    logical, intent(in) :: full
    integer, intent(in) :: ny, nf, j0, j1, nc, cols(nc)
    real(wp), intent(in) :: lw(ny, ny), dy(ny, nf, j1 - j0 + 1), nu(ny, j1 - j0 + 1)
    real(wp), intent(out) :: w(ny, SAMPLE_BLOCK, nc + 1)
    real(wp) :: lwd(ny)
    integer :: j
    if (.not. full) then
      do j = 1, ny
        lwd(j) = lw(j, j)
      end do
      if (ny == 7) then             ! the longitudinal models' seven outputs: a clone
        call weigh_diagonal_block(7, j1 - j0 + 1, nf, nc, cols, lwd, dy, nu, w)
      else
        call weigh_diagonal_block(ny, j1 - j0 + 1, nf, nc, cols, lwd, dy, nu, w)
      end if
      return
    end if
    do j = 1, j1 - j0 + 1
      w(:, j, nc + 1) = matmul(nu(:, j), lw)
      w(:, j, 1:nc) = matmul(transpose(lw), dy(:, cols, j))
    end do
  end subroutine weigh_block

  !> weigh_block for a diagonal R (L's diagonal lwd): each column the
  !> outputs times lwd (ny by value: a constant ny makes a clone whose
  !> rows are whole vector products with lwd held in registers).
  subroutine weigh_diagonal_block(ny, nb, nf, nc, cols, lwd, dy, nu, w)
    integer, value :: ny
    integer, intent(in) :: nb, nf, nc, cols(nc)
    real(wp), intent(in) :: lwd(ny), dy(ny, nf, nb), nu(ny, nb)
    real(wp), intent(out) :: w(ny, SAMPLE_BLOCK, nc + 1)
    integer :: j, c
    do j = 1, nb
      w(:, j, nc + 1) = lwd*nu(:, j)
      do c = 1, nc
        w(:, j, c) = lwd*dy(:, cols(c), j)
      end do
    end do
  end subroutine weigh_diagonal_block

  !> Weighted output i of a block of nb samples, transposed for sym_atb_t:
  !> wt(q, j) = (L' dy(:, cols(q), j))_i, wt(nc+1, j) = (L' nu(:, j))_i,
  !> over the outputs L(:, i) weighs (rows nc+2.. of wt, the tiles'
  !> padding, left as they are: zero).
  subroutine weigh_output(i, ny, nf, nb, nc, cols, lw, dy, nu, ld, wt)
    integer, intent(in) :: i, ny, nf, nb, nc, cols(nc), ld
    real(wp), intent(in) :: lw(ny, ny), dy(ny, nf, nb), nu(ny, nb)
    real(wp), intent(inout) :: wt(ld, nb)
    integer :: j, q, r
    wt(1:nc + 1, :) = 0.0_wp
    do j = 1, nb
      do r = i, ny
        if (lw(r, i) == 0.0_wp) cycle
        do q = 1, nc
          wt(q, j) = wt(q, j) + lw(r, i)*dy(r, cols(q), j)
        end do
        wt(nc + 1, j) = wt(nc + 1, j) + lw(r, i)*nu(r, j)
      end do
    end do
  end subroutine weigh_output

  !> weigh_output for an output L weighs alone (L(i, i) = s, R^-1
  !> diagonal): wt(q, j) = s dy(i, cols(q), j), wt(nc+1, j) = s nu(i, j).
  !> The entries are at offsets worked out once a segment (64-bit, no index
  !> arithmetic per entry): src(q), (i, cols(q)) within a sample's dy(:, :, j).
  subroutine weigh_diagonal(i, ny, nf, nb, nc, src, s, dy, nu, ld, wt)
    integer, intent(in) :: i, ny, nf, nb, nc, ld
    integer(int64), intent(in) :: src(nc)
    real(wp), intent(in) :: s, dy(ny*nf, nb), nu(ny, nb)
    real(wp), intent(inout) :: wt(ld, nb)
    integer :: j, q
    real(wp) :: sl
    sl = s
    do j = 1, nb
      do q = 1, nc
        wt(q, j) = sl*dy(src(q), j)
      end do
      wt(nc + 1, j) = sl*nu(i, j)
    end do
  end subroutine weigh_diagonal

  !> Adds output's product p (nc+1 x nc+1, its upper triangle: its columns
  !> cols, then the residual) to the information f and the gradient g.
  subroutine add_output(cols, p, g, f)
    integer, intent(in) :: cols(:)
    real(wp), intent(in) :: p(size(cols) + 1, size(cols) + 1)
    real(wp), intent(inout) :: g(:), f(:, :)
    integer :: k, l
    do l = 1, size(cols)
      do k = 1, l
        f(cols(k), cols(l)) = f(cols(k), cols(l)) + p(k, l)
        if (k < l) f(cols(l), cols(k)) = f(cols(l), cols(k)) + p(k, l)
      end do
      g(cols(l)) = g(cols(l)) - p(l, size(cols) + 1)
    end do
  end subroutine add_output

  !> wsens(:, j, cols) = R^-1 dy(:, cols, j) over the samples j0..j1.
  subroutine weigh_columns(ny, nf, nt, j0, j1, cols, rinv, dy, wsens)
    integer, intent(in) :: ny, nf, nt, j0, j1, cols(:)
    real(wp), intent(in) :: rinv(ny, ny), dy(ny, nf, nt)
    real(wp), intent(inout) :: wsens(ny, nt, nf)
    integer :: j, c, i, r
    do c = 1, size(cols)
      do j = j0, j1
        do i = 1, ny
          wsens(i, j, cols(c)) = 0.0_wp
          do r = 1, ny
            wsens(i, j, cols(c)) = wsens(i, j, cols(c)) + rinv(i, r)*dy(r, cols(c), j)
          end do
        end do
      end do
    end do
  end subroutine weigh_columns

  !> The weighted sensitivities wsens (ny, nt, nf) from what a full
  !> evaluation kept (likelihood's keep), with segment starts seg: filter
  !> error's B(j)^-1 dnu(j) (fe_block's products); output error's R^-1 dy
  !> over each segment's moving columns (R^-1's diagonal: output i's
  !> columns that move it; the full R^-1: the columns that move any output),
  !> zero where a column leaves an output unmoved.
  subroutine weighted_sensitivities(keep, seg, wsens)
    type(sens_keep_t), intent(in) :: keep
    integer, intent(in) :: seg(:)
    real(wp), intent(out) :: wsens(:, :, :)
    logical, allocatable :: moves(:, :)
    integer, allocatable :: cols(:)
    real(wp), allocatable :: rd(:)
    integer :: ny, nf, nt, s, jbeg, jend, c, i, j

    ny = size(keep%dy, 1)
    nf = size(keep%dy, 2)
    nt = size(keep%dy, 3)
    if (keep%filter) then
      do j = 1, nt
        wsens(:, j, :) = matmul(keep%w(:, :, min(j, size(keep%w, 3))), keep%dy(:, :, j))
      end do
      return
    end if
    allocate (moves(ny, nf), rd(ny))
    do i = 1, ny
      rd(i) = keep%w(i, i, 1)
    end do
    do s = 1, size(seg)
      jbeg = seg(s)
      jend = nt
      if (s < size(seg)) jend = seg(s + 1) - 1
      call moving_outputs(ny, nf, jend - jbeg + 1, keep%dy(:, :, jbeg:jend), moves)
      call zero_unmoved(ny, nf, nt, jbeg, jend, moves, wsens)
      if (keep%full_r) then
        cols = pack([(c, c=1, nf)], any(moves, dim=1))
        call weigh_columns(ny, nf, nt, jbeg, jend, cols, keep%w(:, :, 1), keep%dy, wsens)
        cycle
      end if
      do c = 1, nf
        if (all(moves(:, c))) then       ! (most columns: down the outputs at once)
          do j = jbeg, jend
            wsens(:, j, c) = rd*keep%dy(:, c, j)
          end do
          cycle
        end if
        do i = 1, ny
          if (moves(i, c)) wsens(i, jbeg:jend, c) = rd(i)*keep%dy(i, c, jbeg:jend)
        end do
      end do
    end do
  end subroutine weighted_sensitivities

  !> b takes a's array when its shape is sh (a kept buffer used again);
  !> else b is left as it is.
  subroutine reuse(a, sh, b)
    real(wp), allocatable, intent(inout) :: a(:, :, :), b(:, :, :)
    integer, intent(in) :: sh(3)
    if (allocated(a)) then
      if (all(shape(a) == sh)) call move_alloc(a, b)
    end if
  end subroutine reuse

  subroutine fe_likelihood(m, theta, pm, t, u, y, opt, cost, rhat, yhat, status, msg, grad, &
                           info, sens, msens, bmean, keep)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: cost, rhat(:, :), yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out), optional :: grad(:), info(:, :), sens(:, :), msens(:, :)
    real(wp), intent(out), optional :: bmean(:, :)
    type(sens_keep_t), intent(inout), optional :: keep
    real(wp), allocatable :: nu(:, :), binv(:, :, :), logdet(:), dnu(:, :, :), db(:, :, :, :)
    real(wp), allocatable :: b0(:, :, :)
    real(wp), allocatable :: gpart(:, :), ipart(:, :, :), bpart(:, :, :), vv(:, :, :)
    real(wp) :: bnu(m%ny)
    integer :: ny, nt, nf, j, b, nblk, j0, j1, ist
    logical :: tv

    ny = m%ny
    nt = size(t)
    nf = pm%nf
    if (present(keep) .and. present(grad)) then
      call reuse(keep%w, [ny, ny, nt], binv)
      call reuse(keep%dy, [ny, nf, nt], dnu)
    end if
    ist = 0
    if (.not. allocated(binv)) allocate (binv(ny, ny, nt), stat=ist)
    if (ist == 0) allocate (nu(ny, nt), logdet(nt), stat=ist)
    if (ist /= 0) then
      call no_memory('the innovations of '//itoa(nt)//' samples', real(ny, wp)*(ny + 1)*nt, &
        status, msg)
      return
    end if
    if (present(grad) .and. .not. allocated(dnu)) allocate (dnu(ny, nf, nt), stat=ist)
    if (ist /= 0) then
      call no_memory(sens_text(nt, nf), real(ny, wp)*nf*nt, status, msg)
      return
    end if
    if (present(grad) .and. .not. m%linear .and. opt%partials) then
      allocate (db(ny, ny, nf, nt), b0(ny, ny, nt), stat=ist)
      if (ist /= 0) then
        call no_memory('the covariance partials of '//itoa(nt)//' samples x '//itoa(nf)// &
          ' parameters', real(ny, wp)*ny*(nf + 1)*nt, status, msg)
        return
      end if
      call kf_innovations(m, theta, pm, t, u, y, opt, yhat, nu, binv, logdet, status, msg, &
                          bhist=b0)
      if (status == MLID_OK) call numerical_partials(m, theta, pm, t, u, y, opt, nu, b0, dnu, db, &
                                                     status, msg)
    else if (present(grad)) then
      allocate (db(ny, ny, nf, merge(1, nt, opt%steady)), stat=ist)
      if (ist /= 0) then
        call no_memory('the covariance partials of '//itoa(nt)//' samples x '//itoa(nf)// &
          ' parameters', real(ny, wp)*ny*nf*merge(1, nt, opt%steady), status, msg)
        return
      end if
      db = 0.0_wp
      call kf_innovations(m, theta, pm, t, u, y, opt, yhat, nu, binv, logdet, status, msg, dnu, db)
    else
      call kf_innovations(m, theta, pm, t, u, y, opt, yhat, nu, binv, logdet, status, msg)
    end if
    if (status /= MLID_OK) return
    if (present(bmean)) call mean_covariance(binv, opt%steady, bmean)
    cost = 0.0_wp
    do j = 1, nt                    ! B^-1 nu into bnu: no temporary per sample
      bnu = matmul(binv(:, :, j), nu(:, j))
      cost = cost + 0.5_wp*(dot_product(nu(:, j), bnu) + logdet(j))
    end do
    rhat = matmul(nu, transpose(nu))/nt
    if (.not. (present(grad) .and. present(info))) return
    if (present(sens)) call sensitivity_norms(dnu, rhat, sens)

    ! samples in parallel, in NBLOCK fixed blocks whose sums are added in
    ! order: the result does not depend on the number of threads
    nblk = min(NBLOCK, nt)
    tv = opt%partials .and. .not. opt%steady       ! B's terms at every sample
    allocate (gpart(nf, nblk), ipart(nf, nf, nblk), bpart(nf, nf, nblk), vv(ny, ny, nblk))
    !$omp parallel do schedule(static) default(shared) private(b, j0, j1)
    do b = 1, nblk
      j0 = (b - 1)*nt/nblk + 1
      j1 = b*nt/nblk
      if (tv) then
        call fe_block(binv(:, :, j0:j1), nu(:, j0:j1), dnu(:, :, j0:j1), opt%partials, &
                      gpart(:, b), ipart(:, :, b), vv(:, :, b), bpart(:, :, b), &
                      db(:, :, :, j0:j1))
      else
        call fe_block(binv(:, :, j0:j1), nu(:, j0:j1), dnu(:, :, j0:j1), opt%partials, &
                      gpart(:, b), ipart(:, :, b), vv(:, :, b))
      end if
    end do
    !$omp end parallel do
    grad = 0.0_wp
    info = 0.0_wp
    do b = 1, nblk
      grad = grad + gpart(:, b)
      info = info + ipart(:, :, b)
    end do
    ! msens: info without the noise-covariance terms 1/2 tr(..)
    if (present(msens)) msens = info
    if (tv) then
      do b = 1, nblk
        info = info + bpart(:, :, b)
      end do
    end if
    if (opt%partials .and. opt%steady) then
      ! B and dB the same at every sample: their terms once, times the samples
      vv(:, :, 1) = sum(vv, dim=3)
      call add_b_partials(binv(:, :, 1), db(:, :, :, 1), vv(:, :, 1), real(nt, wp), grad, info)
    end if
    if (present(keep)) then
      call move_alloc(dnu, keep%dy)
      if (opt%steady) then              ! B the same at every sample: one kept
        keep%w = binv(:, :, 1:1)
      else
        call move_alloc(binv, keep%w)
      end if
      keep%filter = .true.
      keep%full_r = .false.
    end if
  end subroutine fe_likelihood

  !> One block of samples' part of the filter-error gradient and information
  !> (eqs 4.30, 4.37): g = sum dnu' B^-1 nu, f = sum dnu' B^-1 dnu as one
  !> symmetric product over the block's samples and outputs (add_sym_atb);
  !> vv = sum B^-1 nu nu' B^-1 (for B's terms, with partials); and with db
  !> (B's partials at every sample) fb = 1/2 sum tr(B^-1 dB_k B^-1 dB_l), a
  !> symmetric product too, and B's terms of g.  The block's arrays are made once, not per sample.
  subroutine fe_block(binv, nu, dnu, partials, g, f, vv, fb, db)
    real(wp), intent(in) :: binv(:, :, :), nu(:, :), dnu(:, :, :)
    logical, intent(in) :: partials
    real(wp), intent(out) :: g(:), f(:, :), vv(:, :)
    real(wp), intent(out), optional :: fb(:, :)
    real(wp), intent(in), optional :: db(:, :, :, :)
    real(wp), allocatable :: x(:, :), w(:, :), v(:), e(:, :), et(:, :)
    real(wp) :: bnu(size(nu, 1)), v1(size(nu, 1), size(nu, 1)), ek(size(nu, 1), size(nu, 1))
    integer :: ny, nf, nb, j, k, i, r, q

    ny = size(nu, 1)
    nf = size(dnu, 2)
    nb = size(nu, 2)
    allocate (x(ny*nb, nf), w(ny*nb, nf), v(ny*nb))
    if (present(db)) allocate (e(ny*ny*nb, nf), et(ny*ny*nb, nf))
    g = 0.0_wp
    f = 0.0_wp
    vv = 0.0_wp
    do j = 1, nb
      r = ny*(j - 1)
      bnu = matmul(binv(:, :, j), nu(:, j))
      v(r + 1:r + ny) = bnu
      x(r + 1:r + ny, :) = dnu(:, :, j)
      w(r + 1:r + ny, :) = matmul(binv(:, :, j), dnu(:, :, j))
      if (.not. partials) cycle
      do k = 1, ny                  ! B^-1 nu nu' B^-1
        v1(:, k) = bnu*bnu(k)
      end do
      vv = vv + v1
      if (.not. present(db)) cycle
      q = ny*ny*(j - 1)
      do k = 1, nf                  ! E_k = B^-1 dB_k, as columns vec(E_k), vec(E_k')
        ek = matmul(binv(:, :, j), db(:, :, k, j))
        g(k) = g(k) + 0.5_wp*(trace(ek) - sum(db(:, :, k, j)*v1))
        do i = 1, ny
          e(q + ny*(i - 1) + 1:q + ny*i, k) = ek(:, i)
          et(q + ny*(i - 1) + 1:q + ny*i, k) = ek(i, :)
        end do
      end do
    end do
    call add_atv(ny*nb, nf, x, v, g)
    call add_sym_atb(ny*nb, nf, x, w, f)
    if (present(db)) then
      fb = 0.0_wp
      call add_sym_atb(ny*ny*nb, nf, e, et, fb)
      fb = 0.5_wp*fb
    end if
  end subroutine fe_block

  !> The mean of B(j) over the samples from the B(j)^-1 the filter keeps
  !> (one inverse with the steady-state gain, where they are all the same).
  subroutine mean_covariance(binv, steady, bmean)
    real(wp), intent(in) :: binv(:, :, :)
    logical, intent(in) :: steady
    real(wp), intent(out) :: bmean(:, :)
    real(wp) :: b(size(bmean, 1), size(bmean, 1)), logdet
    integer :: j, ierr
    bmean = 0.0_wp
    do j = 1, merge(1, size(binv, 3), steady)
      call chol_inverse(binv(:, :, j), b, logdet, ierr)
      bmean = bmean + b
    end do
    bmean = bmean/merge(1, size(binv, 3), steady)
  end subroutine mean_covariance

  !> The terms of grad and info through dB (eqs 4.30, 4.37) over n samples
  !> with the same B and dB: 1/2 (n tr(B^-1 dB_k) - tr(dB_k V)) and
  !> n/2 tr(B^-1 dB_k B^-1 dB_l), where V is B^-1 nu nu' B^-1 summed over
  !> those samples.
  pure subroutine add_b_partials(binv, db, v, n, g, f)
    real(wp), intent(in) :: binv(:, :), db(:, :, :), v(:, :), n
    real(wp), intent(inout) :: g(:), f(:, :)
    real(wp) :: e(size(binv, 1), size(binv, 1)), ev(size(binv, 1)**2, size(db, 3)), &
                evt(size(binv, 1)**2, size(db, 3))
    integer :: k, ny
    ny = size(binv, 1)
    do k = 1, size(db, 3)
      e = matmul(binv, db(:, :, k))                   ! B^-1 dB_k
      g(k) = g(k) + 0.5_wp*(n*trace(e) - sum(db(:, :, k)*v))
      ev(:, k) = reshape(e, [ny*ny])
      evt(:, k) = reshape(transpose(e), [ny*ny])
    end do
    f = f + (0.5_wp*n)*matmul(transpose(ev), evt)    ! tr(E_k E_l) for all k, l at once
  end subroutine add_b_partials

  !> dnu/dtheta and dB/dtheta of the filter by forward differences from the
  !> nominal run (nu0, b0): Gauss-Newton needs them to a relative 1e-6, not
  !> more, and one run per parameter halves the cost of central ones.  The
  !> step is 1e-6 of the parameter, or of the mean magnitude of its block
  !> (model, x0, bias, q, r, s) when it is zero; upward, so that a variance
  !> at zero stays admissible.
  subroutine numerical_partials(m, theta, pm, t, u, y, opt, nu0, b0, dnu, db, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :), y(:, :), nu0(:, :), b0(:, :, :)
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: dnu(:, :, :), db(:, :, :, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: yh(:, :), nup(:, :), bi(:, :, :), ld(:), bp(:, :, :)
    real(wp) :: th(size(theta)), h
    integer :: k, i, ny, nt, blk(11), kstat(pm%nf)
    character(len=len(msg)) :: kmsg(pm%nf)

    ny = m%ny
    nt = size(t)
    blk = [0, pm%l%ox0, pm%l%obias, pm%l%oq, pm%l%or, pm%l%os, pm%l%odelay, pm%l%oudelay, &
           pm%l%ostab, pm%l%op0, pm%l%nth]
    kstat = MLID_OK
    ! one whole filter run per parameter, independent of the others
    !$omp parallel do schedule(dynamic) default(shared) private(k, i, h, th, yh, nup, bi, ld, bp)
    do k = 1, pm%nf
      allocate (yh(ny, nt), nup(ny, nt), bi(ny, ny, nt), ld(nt), bp(ny, ny, nt))
      i = pm%ifree(k)
      h = 1.0e-6_wp*abs(theta(i))
      if (h == 0.0_wp) h = 1.0e-6_wp*block_scale(i)
      th = theta
      th(i) = theta(i) + h
      h = th(i) - theta(i)          ! the step actually taken
      call apply_ties(pm%tie, th)
      call kf_innovations(m, th, pm, t, u, y, opt, yh, nup, bi, ld, kstat(k), kmsg(k), bhist=bp)
      if (kstat(k) == MLID_OK) then
        dnu(:, k, :) = (nup - nu0)/h
        db(:, :, k, :) = (bp - b0)/h
      end if
      deallocate (yh, nup, bi, ld, bp)
    end do
    !$omp end parallel do
    call first_failure(kstat, kmsg, status, msg)
    if (status /= MLID_OK) return

  contains

    real(wp) function block_scale(i)
      integer, intent(in) :: i
      integer :: b
      real(wp), allocatable :: v(:)
      block_scale = 1.0_wp
      do b = 1, size(blk) - 1
        if (i > blk(b) .and. i <= blk(b + 1)) then
          v = pack(abs(theta(blk(b) + 1:blk(b + 1))), theta(blk(b) + 1:blk(b + 1)) /= 0.0_wp)
          if (size(v) > 0) block_scale = sum(v)/size(v)
        end if
      end do
    end function block_scale

  end subroutine numerical_partials

  !> sqrt(sum_t ds(i,k,t)^2 / r(i,i)) for each output i and parameter k.
  pure subroutine sensitivity_norms(ds, r, sens)
    real(wp), intent(in) :: ds(:, :, :), r(:, :)
    real(wp), intent(out) :: sens(:, :)
    integer :: i
    do i = 1, size(sens, 1)
      sens(i, :) = sqrt(sum(ds(i, :, :)**2, dim=2)/r(i, i))
    end do
  end subroutine sensitivity_norms

  pure real(wp) function trace(a)
    real(wp), intent(in) :: a(:, :)
    integer :: i
    trace = 0.0_wp
    do i = 1, size(a, 1)
      trace = trace + a(i, i)
    end do
  end function trace

  !> What a fit's sensitivities are, for a message that they do not fit in memory.
  function sens_text(nt, nf) result(text)
    integer, intent(in) :: nt, nf
    character(len=:), allocatable :: text
    text = 'the sensitivities of '//itoa(nt)//' samples x '//itoa(nf)//' parameters'
  end function sens_text

end module mlid_likelihood
