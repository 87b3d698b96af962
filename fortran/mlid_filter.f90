!> State estimation along a record and the sensitivity recursions
!> (report §4.1, §4.3).
!>
!> oe_predict: with no process noise the gain is zero and the filter reduces
!>   to the output-error predictor (§4.4); innovations are output errors.
!> kf_innovations: the Kalman filter for process noise w held over each
!>   sample interval (variance Q, entering through df/dw) and measurement
!>   noise v (variance R) correlated with the noise of the interval that
!>   follows (S = E{w v'}, the forward correlation of §5.1.5-5.1.7):
!>
!>     update   B = C P C' + R,  K = P C' B^-1,  x+ = x- + K nu,  P+ = (I - K C) P-
!>     predict  x- = RK4 step of f(x, [u; w^]) from x+, with w^ = S B^-1 nu,
!>              P- = Phi P+ Phi' + W (Q - S B^-1 S') W' - Phi K S' W' - W S K' Phi'
!>
!>   where Phi and W are the RK4 step's transition for the state and the held
!>   noise.  The sensitivities d x^/d theta follow eqs 4.35-4.36 and, with
!>   opt%partials, the covariance partials dP, dK, dB of eqs 4.32-4.34 (the
!>   "added partials" of Appendix B).  With opt%steady the gain is held at its
!>   steady-state value.
!>   For a nonlinear model the same recursion is the extended Kalman filter
!>   (eqs 4.22-4.28): C is dh/dx at x(j|j-1), Phi and W are the Jacobians of
!>   the RK4 interval at x(j-1|j-1), integrated with the state.  The
!>   partials this routine would form for it hold the linearisation fixed
!>   (none through Phi, W, C, nor through the effective R and S of outputs
!>   that carry the process noise), so mlid_likelihood does not ask for
!>   them: with opt%partials it differences whole filter runs instead.  The
!>   steady-state gain needs a linear model.
module mlid_filter
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_DIVERGED, MLID_ERR_INPUT, MLID_ERR_SINGULAR, &
                        MLID_ERR_NOCONV, first_failure
  use mlid_linalg, only: chol_inverse
  use mlid_models, only: model_t, layout_t
  use mlid_options, only: options_t
  use mlid_params, only: param_map_t, segment_map, input_delays, output_delays, stabilized
  use mlid_rk, only: rk4_step, rk4_interval, input_sens_t, rk_work_t
  use mlid_delay, only: delay_outputs, delay_check
  implicit none
  private
  public :: oe_predict, kf_innovations

  !> Filter covariance quantities at one sample and their partials.
  type :: cov_t
    real(wp), allocatable :: pm(:, :), dpm(:, :, :)    !< P(j|j-1) and dP
    real(wp), allocatable :: pp(:, :), dpp(:, :, :)    !< P(j|j) and dP
    real(wp), allocatable :: b(:, :), binv(:, :), db(:, :, :)
    real(wp), allocatable :: k(:, :), dk(:, :, :)
    real(wp) :: logdet = 0.0_wp
  end type cov_t

  !> What the filter needs that does not change along a record.
  type :: lti_t
    real(wp), allocatable :: c(:, :), dc(:, :, :)      !< dh/dx and its partials
    real(wp), allocatable :: phi(:, :), dphi(:, :, :)  !< state transition over an interval
    real(wp), allocatable :: w(:, :), dw(:, :, :)      !< held-noise transition
    real(wp), allocatable :: q(:, :), dq(:, :, :), r(:, :), dr(:, :, :), s(:, :), ds(:, :, :)
    real(wp), allocatable :: r0(:, :), s0(:, :)       !< R and S of the parameters alone
    real(wp), allocatable :: g(:, :)                   !< df/dw
    !> Which partials are non-zero, per free parameter (most are zero:
    !> only F and Gamma move Phi and W, only q, r, s move Q, R, S).
    logical, allocatable :: nz_phi(:), nz_w(:), nz_c(:), nz_q(:), nz_r(:), nz_s(:)
    real(wp) :: dt = -1.0_wp
  end type lti_t

contains

  !> Model outputs yhat(ny, nt) along the record and, if dy is present,
  !> their sensitivities dy(ny, nf, nt) to the free parameters.
  !> xhist(nx, nt), if present, receives the states.  The manoeuvres
  !> (segments) are independent, each from its own initial state, and are
  !> integrated in parallel: each writes only its own samples, so the result
  !> does not depend on the threads; a failure is the first segment's.
  subroutine oe_predict(m, theta, pm, t, u, opt, yhat, status, msg, dy, xhist, z)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :)
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out), optional :: dy(:, :, :)
    real(wp), intent(out), optional :: xhist(:, :)
    real(wp), intent(in), optional :: z(:, :)     !< the measured outputs (stabilized output error)
    integer :: k, nseg, first(pm%l%nseg + 1), kstat(pm%l%nseg)
    character(len=len(msg)) :: kmsg(pm%l%nseg)

    nseg = pm%l%nseg
    first(1:nseg) = pm%l%seg
    first(nseg + 1) = size(t) + 1
    !$omp parallel do schedule(dynamic, 1) if (nseg > 1)
    do k = 1, nseg
      call oe_manoeuvre(m, theta, pm, t, u, opt, k, first(k), first(k + 1) - 1, yhat, &
                        kstat(k), kmsg(k), dy, xhist, z)
    end do
    !$omp end parallel do
    call first_failure(kstat, kmsg, status, msg)
  end subroutine oe_predict

  !> oe_segment on the model with the inputs that keep one value over the
  !> segment folded in (model_t%fold_inputs), and with sensitivities only
  !> for the free parameters that can move it (mlid_params' segment_map):
  !> a bias of another manoeuvre, stated with that one's indicator input,
  !> costs this one nothing.  Results are those of oe_segment on m up to
  !> rounding (mlid_expr_diff's graph_fold).
  subroutine oe_manoeuvre(m, theta, pm, t, u, opt, iseg, j0, j1, yhat, status, msg, dy, xhist, &
                          z)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :)
    type(options_t), intent(in) :: opt
    integer, intent(in) :: iseg, j0, j1
    real(wp), intent(inout) :: yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(inout), optional :: dy(:, :, :), xhist(:, :)
    real(wp), intent(in), optional :: z(:, :)
    class(model_t), allocatable :: mf
    type(param_map_t) :: pk
    integer, allocatable :: cols(:)
    real(wp), allocatable :: dyk(:, :, :)
    logical :: fixed(m%nu), used(m%np)
    integer :: i, c

    do i = 1, m%nu
      fixed(i) = all(u(i, j0:j1) == u(i, j0))
    end do
    call m%fold_inputs(fixed, u(:, j0), mf)
    if (.not. allocated(mf)) then
      call oe_segment(m, theta, pm, t, u, opt, iseg, j0, j1, yhat, status, msg, dy, xhist, z)
    else if (.not. present(dy)) then
      call oe_segment(mf, theta, pm, t, u, opt, iseg, j0, j1, yhat, status, msg, xhist=xhist, z=z)
    else
      call mf%uses_params(used)
      call segment_map(pm, iseg, used, pk, cols)
      allocate (dyk(m%ny, pk%nf, size(t)))
      call oe_segment(mf, theta, pk, t, u, opt, iseg, j0, j1, yhat, status, msg, dyk, xhist, z)
      do c = 1, pm%nf
        if (all(cols /= c)) dy(:, c, j0:j1) = 0.0_wp
      end do
      dy(:, cols, j0:j1) = dyk(:, :, j0:j1)
    end if
  end subroutine oe_manoeuvre

  !> oe_predict over the samples j0..j1 of segment iseg.  Inputs that a
  !> delay moves (udelay) are delayed first (mlid_delay), and force the
  !> sensitivities through df/du and dh/du.  With a stabilizing gain K
  !> (theta's block stab, nx x ny), the stabilized output error of the
  !> textbook (its eq. 9.37): after the outputs of each sample, x <- x +
  !> K (z - yhat) and its sensitivities s <- s - K dy, before integrating on.
  subroutine oe_segment(m, theta, pm, t, u, opt, iseg, j0, j1, yhat, status, msg, dy, xhist, z)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :)
    type(options_t), intent(in) :: opt
    integer, intent(in) :: iseg, j0, j1
    real(wp), intent(inout) :: yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(inout), optional :: dy(:, :, :)
    real(wp), intent(inout), optional :: xhist(:, :)
    real(wp), intent(in), optional :: z(:, :)
    real(wp), allocatable :: ud(:, :), dud(:, :)
    real(wp) :: gain(m%nx, m%ny)
    logical :: stab

    status = MLID_OK
    msg = ''
    associate (l => pm%l)
      gain = reshape(theta(l%ostab + 1:l%ostab + m%nx*m%ny), [m%nx, m%ny])
      stab = stabilized(theta, l)
      if (stab .and. .not. present(z)) then
        msg = 'the stabilized output error (stab) needs the measured outputs'
      else if (stab .and. output_delays(theta, pm)) then
        msg = 'the stabilized output error (stab) takes no output time delays'
      end if
      if (len_trim(msg) > 0) then
        status = MLID_ERR_INPUT
        return
      end if
      if (input_delays(theta, pm)) then
        call delay_check(theta(l%oudelay + 1:l%oudelay + l%nu), t, j0, j1, iseg, 'udelay', &
                         status, msg)
        if (status /= MLID_OK) return
        if (present(dy) .and. size(pm%iu) > 0) then   ! a moving delay forces the sensitivities
          call delayed_inputs(theta, pm, t, u, j0, j1, ud, dud)
          call integrate(ud, dud)
        else
          call delayed_inputs(theta, pm, t, u, j0, j1, ud)
          call integrate(ud)
        end if
      else
        call integrate(u)
      end if
      if (status /= MLID_OK) return
      call delay_check(theta(l%odelay + 1:l%odelay + l%ny), t, j0, j1, iseg, 'delay', status, msg)
      if (status /= MLID_OK) return
      if (present(dy)) then                  ! sensors that report late (mlid_delay)
        call delay_outputs(theta(l%odelay + 1:l%odelay + l%ny), t, j0, j1, yhat, dy, pm%id, &
                           pm%cd, pm%wd)
      else
        call delay_outputs(theta(l%odelay + 1:l%odelay + l%ny), t, j0, j1, yhat)
      end if
    end associate

  contains

    !> States, outputs and sensitivities over the segment on the inputs uu;
    !> du(k, j): how moving input delay k moves its input at sample j.
    subroutine integrate(uu, du)
      real(wp), intent(in) :: uu(:, :)
      real(wp), intent(in), optional :: du(:, :)
      real(wp), allocatable :: s(:, :), c(:, :), d(:, :), hu(:, :)
      type(input_sens_t) :: us
      type(rk_work_t) :: wk
      real(wp) :: x(m%nx)
      integer :: j, k

      if (present(dy)) allocate (c(m%ny, m%nx), d(m%ny, size(pm%im)), hu(m%ny, m%nu))
      x = theta(pm%l%ox0 + (iseg - 1)*m%nx + 1:pm%l%ox0 + iseg*m%nx)
      if (present(dy)) s = initial_sensitivity(pm, iseg)
      if (present(du)) us = input_sens_t(pm%iu, pm%cu, du(:, j0), du(:, j0))
      do j = j0, j1
        if (j > j0) then
          if (present(dy) .and. present(du)) then
            us%d0 = du(:, j - 1)
            us%d1 = du(:, j)
            call advance(m, theta, pm, t, uu, opt, j - 1, [real(wp) ::], x, wk, s, us=us)
          else if (present(dy)) then
            call advance(m, theta, pm, t, uu, opt, j - 1, [real(wp) ::], x, wk, s)
          else
            call advance(m, theta, pm, t, uu, opt, j - 1, [real(wp) ::], x, wk)
          end if
          if (.not. all(ieee_is_finite(x))) then
            call diverged(t(j), status, msg)
            return
          end if
        end if
        if (present(xhist)) xhist(:, j) = x
        call m%h(t(j), x, uu(:, j), theta(1:pm%l%np), yhat(:, j))
        yhat(:, j) = yhat(:, j) + theta(pm%l%obias + (iseg - 1)*m%ny + 1:pm%l%obias + iseg*m%ny)
        if (present(dy)) then
          call output_sensitivity(m, theta, pm, t(j), x, uu(:, j), s, dy(:, :, j), c, d, iseg)
          if (present(du)) then
            call m%dhdu(t(j), x, uu(:, j), theta(1:pm%l%np), hu)
            do k = 1, size(pm%iu)
              dy(:, pm%cu(k), j) = dy(:, pm%cu(k), j) + hu(:, pm%iu(k))*du(k, j)
            end do
          end if
        end if
        if (.not. stab) cycle
        x = x + matmul(gain, z(:, j) - yhat(:, j))
        if (present(dy)) s = s - matmul(gain, dy(:, :, j))
      end do
    end subroutine integrate

  end subroutine oe_segment


  !> The inputs with segment j0..j1 delayed (mlid_delay) and, if asked for,
  !> du(k, j): the moving input delay k's effect on its input at sample j (a
  !> tie's scale in it).
  subroutine delayed_inputs(theta, pm, t, u, j0, j1, ud, du)
    real(wp), intent(in) :: theta(:), t(:), u(:, :)
    type(param_map_t), intent(in) :: pm
    integer, intent(in) :: j0, j1
    real(wp), allocatable, intent(out) :: ud(:, :)
    real(wp), allocatable, intent(out), optional :: du(:, :)
    real(wp), allocatable :: dall(:, :, :)
    integer :: k, nk
    associate (tau => theta(pm%l%oudelay + 1:pm%l%oudelay + pm%l%nu))
      ud = u
      if (.not. present(du)) then
        call delay_outputs(tau, t, j0, j1, ud)
        return
      end if
      nk = size(pm%iu)
      allocate (dall(pm%l%nu, nk, size(t)), du(nk, size(t)))
      dall(:, :, j0:j1) = 0.0_wp
      call delay_outputs(tau, t, j0, j1, ud, dall, pm%iu, [(k, k=1, nk)], pm%wu)
      du = 0.0_wp
      do k = 1, nk
        du(k, j0:j1) = dall(pm%iu(k), k, j0:j1)
      end do
    end associate
  end subroutine delayed_inputs

  !> Innovations nu(ny, nt) and their covariances through binv(ny, ny, nt)
  !> and logdet(nt); with dnu present also their sensitivities
  !> dnu(ny, nf, nt) and, with opt%partials, db(ny, ny, nf, nt).
  !> yhat(ny, nt) receives the one-step predictions.
  subroutine kf_innovations(m, theta, pm, t, u, y, opt, yhat, nu, binv, logdet, status, msg, &
                            dnu, db, bhist)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: yhat(:, :), nu(:, :), binv(:, :, :), logdet(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out), optional :: dnu(:, :, :), db(:, :, :, :)
    real(wp), intent(out), optional :: bhist(:, :, :)   !< B(j) itself
    type(layout_t) :: l
    type(lti_t) :: sys
    type(cov_t) :: cv
    real(wp), allocatable :: s(:, :), c(:, :), d(:, :), what(:), dwhat(:, :)
    real(wp), allocatable :: sj(:, :), fj(:, :)
    real(wp) :: x(m%nx), dhw(m%ny, m%nw), sb(m%nw, m%ny)
    type(rk_work_t) :: wk
    integer :: j, k, nf, nx, nw, ns, iseg
    logical :: sens, partials, ekf

    status = MLID_OK
    msg = ''
    l = pm%l
    nf = pm%nf
    sens = present(dnu)
    ekf = .not. m%linear
    partials = sens .and. opt%partials
    nx = l%nx
    nw = l%nw
    call lti_setup(m, theta, pm, t, u, opt, sys, status, msg)
    if (status /= MLID_OK) return
    ns = merge(nf, 0, sens)
    if (ekf) then
      ! columns: the parameter sensitivities (if wanted), then Phi, then W
      allocate (sj(nx, ns + nx + nw), fj(nx, ns + nx + nw))
    end if
    call cov_alloc(cv, l%nx, l%ny, nf)
    allocate (c(l%ny, l%nx), d(l%ny, size(pm%im)), what(l%nw), dwhat(l%nw, nf))
    if (opt%steady) then
      call steady_state(sys, cv, partials, status, msg)
      if (status /= MLID_OK) return
    end if
    iseg = 0

    do j = 1, size(t)
      if (segment_starts(l, j, iseg)) then
        ! each manoeuvre from its own (known) initial state: P = 0
        x = theta(l%ox0 + (iseg - 1)*l%nx + 1:l%ox0 + iseg*l%nx)
        s = initial_sensitivity(pm, iseg)
        what = 0.0_wp
        dwhat = 0.0_wp
        if (j > 1 .and. .not. opt%steady) then
          cv%pm = 0.0_wp
          cv%dpm = 0.0_wp
        end if
      else
        if (ekf) then               ! linearise the interval about x(j-1|j-1), eq. 4.27
          call m%dfdw(t(j - 1), x, [u(:, j - 1), what], theta(1:l%np), sys%g)
          sj = 0.0_wp
          fj = 0.0_wp
          if (sens) then
            sj(:, 1:nf) = s
            fj(:, 1:nf) = matmul(sys%g, dwhat)
          end if
          do k = 1, nx
            sj(k, ns + k) = 1.0_wp
          end do
          fj(:, ns + nx + 1:) = sys%g
          if (sens) then
            call advance(m, theta, pm, t, u, opt, j - 1, what, x, wk, sj, fj)
            s = sj(:, 1:nf)
          else          ! no parameter columns: nothing may force them
            call advance_plain(m, theta, pm, t, u, opt, j - 1, what, x, wk, sj, fj)
          end if
          sys%phi = sj(:, ns + 1:ns + nx)
          sys%w = sj(:, ns + nx + 1:)
        else if (sens) then
          call advance(m, theta, pm, t, u, opt, j - 1, what, x, wk, s, matmul(sys%g, dwhat))
        else
          call advance(m, theta, pm, t, u, opt, j - 1, what, x, wk)
        end if
        if (.not. all(ieee_is_finite(x))) then
          call diverged(t(j), status, msg)
          return
        end if
        if (.not. opt%steady) call cov_predict(sys, cv, partials)
      end if
      if (ekf) then
        call m%dhdx(t(j), x, u(:, j), theta(1:l%np), sys%c)
        ! outputs that carry the process noise of the next interval, (dh/dw) w:
        ! the effective R and S at this sample (report §5.1.7)
        call m%dhdw(t(j), x, u(:, j), theta(1:l%np), dhw)
        if (any(dhw /= 0.0_wp)) then
          sys%r = sys%r0 + matmul(dhw, matmul(sys%q, transpose(dhw)))
          sys%s = sys%s0 + matmul(sys%q, transpose(dhw))
        end if
      end if
      if (.not. opt%steady) then
        call cov_update(sys, cv, partials, status, msg)
        if (status /= MLID_OK) then
          write (msg, '(a,g0.6,a)') trim(msg)//' at t = ', t(j)
          return
        end if
      end if
      call m%h(t(j), x, u(:, j), theta(1:l%np), yhat(:, j))
      yhat(:, j) = yhat(:, j) + theta(l%obias + (iseg - 1)*l%ny + 1:l%obias + iseg*l%ny)
      nu(:, j) = y(:, j) - yhat(:, j)
      binv(:, :, j) = cv%binv
      logdet(j) = cv%logdet
      if (present(bhist)) bhist(:, :, j) = cv%b
      if (sens) then                ! d nu = -(C dx(j|j-1) + dh/dp + d bias), eq. 4.31
        call output_sensitivity(m, theta, pm, t(j), x, u(:, j), s, dnu(:, :, j), c, d, iseg)
        dnu(:, :, j) = -dnu(:, :, j)
      end if
      ! state update and the held-noise estimate for the next interval
      x = x + matmul(cv%k, nu(:, j))
      sb = matmul(sys%s, cv%binv)
      what = matmul(sb, nu(:, j))
      if (sens) then                ! eq. 4.36
        s = s + matmul(cv%k, dnu(:, :, j))
        dwhat = matmul(sb, dnu(:, :, j))
        if (partials) then
          db(:, :, :, j) = cv%db
          do k = 1, nf
            s(:, k) = s(:, k) + matmul(cv%dk(:, :, k), nu(:, j))
            dwhat(:, k) = dwhat(:, k) + matmul(sys%ds(:, :, k), matmul(cv%binv, nu(:, j))) &
                          - matmul(sb, matmul(cv%db(:, :, k), matmul(cv%binv, nu(:, j))))
          end do
        end if
      end if
    end do
  end subroutine kf_innovations

  !> Everything the filter holds fixed along the record (linear models):
  !> C, Phi, W = held-noise transition, Q, R, S and their partials.
  subroutine lti_setup(m, theta, pm, t, u, opt, sys, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :)
    type(options_t), intent(in) :: opt
    type(lti_t), intent(out) :: sys
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(layout_t) :: l
    real(wp) :: dt, e(m%nx), ua(m%nu + m%nw), dcm(m%ny, m%nx, size(pm%im)), a(m%nx, m%nx)
    real(wp), allocatable :: sk(:, :), s0step(:, :)
    real(wp) :: x0step(m%nx)
    integer :: i, k, nf, nx, nw, ny
    type(options_t) :: o1

    status = MLID_ERR_INPUT
    l = pm%l
    nf = pm%nf
    nx = l%nx
    nw = l%nw
    ny = l%ny
    if (.not. m%linear .and. opt%steady) then
      msg = 'the steady-state gain needs a linear model (a nonlinear model uses the extended '// &
            'Kalman filter with its time-varying gain)'
      return
    end if
    dt = t(2) - t(1)
    do k = 2, size(t) - 1
      if (any(l%seg == k + 1)) cycle                  ! a new manoeuvre: its own time base
      if (abs((t(k + 1) - t(k)) - dt) > 1.0e-3_wp*dt) then   ! recorded times are rounded
        write (msg, '(a,i0)') 'the Kalman filter needs uniform sampling; time step changes at sample ', k + 1
        return
      end if
    end do
    do k = 1, nw
      if (.not. theta(l%oq + k) >= 0.0_wp) then
        write (msg, '(a,i0,a)') 'process-noise variance q(', k, ') must be >= 0'
        return
      end if
    end do
    do k = 1, ny
      if (.not. theta(l%or + k) > 0.0_wp) then
        write (msg, '(a,i0,a)') 'measurement-noise variance r(', k, ') must be > 0'
        return
      end if
    end do
    allocate (sys%c(ny, nx), sys%dc(ny, nx, nf), sys%phi(nx, nx), sys%dphi(nx, nx, nf), &
              sys%w(nx, nw), sys%dw(nx, nw, nf), sys%q(nw, nw), sys%dq(nw, nw, nf), &
              sys%r(ny, ny), sys%dr(ny, ny, nf), sys%s(nw, ny), sys%ds(nw, ny, nf), &
              sys%g(nx, nw), sk(nx, nf), s0step(nx, nf))
    sys%dt = dt
    ua = 0.0_wp
    e = theta(l%ox0 + 1:l%ox0 + nx)
    call m%dhdx(t(1), e, u(:, 1), theta(1:l%np), sys%c)
    call m%dfdw(t(1), e, ua, theta(1:l%np), sys%g)
    sys%dc = 0.0_wp
    call m%dhdxp(t(1), e, u(:, 1), theta(1:l%np), pm%im, dcm)
    do k = 1, size(pm%im)
      sys%dc(:, :, pm%cm(k)) = sys%dc(:, :, pm%cm(k)) + pm%wm(k)*dcm(:, :, k)
    end do
    ! A state driven only by process noise and by itself is a noise-shaping
    ! (gust) state: its pole must be negative, or the "gust" grows without bound.
    call m%dfdx(t(1), e, ua, theta(1:l%np), a)
    do i = 1, nx
      if (any(sys%g(i, :) /= 0.0_wp) .and. all(pack(a(i, :), [(k /= i, k=1, nx)]) == 0.0_wp) &
          .and. .not. a(i, i) < 0.0_wp) then
        write (msg, '(a,i0,a,i0,a,i0,a,g0.6,a)') 'gust state ', i, ' (driven only by process '// &
          'noise) has a time constant of the wrong sign: f(', i, ',', i, ') = ', a(i, i), &
          ' must be < 0'
        return
      end if
    end do
    ! Phi and W: one interval of the integrator applied to unit states and
    ! unit held noise; their partials from the same step's sensitivities.
    ! (a nonlinear model gets them at each interval, in kf_innovations)
    ! The model may be affine (state-equation biases): the step from zero
    ! state and noise is subtracted, leaving the linear part.
    o1 = opt
    sys%phi = 0.0_wp
    sys%dphi = 0.0_wp
    sys%w = 0.0_wp
    sys%dw = 0.0_wp
    ua = 0.0_wp
    x0step = 0.0_wp
    s0step = 0.0_wp
    if (m%linear) call integrate(x0step, ua, s0step)
    do i = 1, merge(nx, 0, m%linear)
      e = 0.0_wp
      e(i) = 1.0_wp
      sk = 0.0_wp
      call integrate(e, ua, sk)
      sys%phi(:, i) = e - x0step
      sys%dphi(:, i, :) = sk - s0step
    end do
    do i = 1, merge(nw, 0, m%linear)
      e = 0.0_wp
      ua = 0.0_wp
      ua(m%nu + i) = 1.0_wp
      sk = 0.0_wp
      call integrate(e, ua, sk)
      sys%w(:, i) = e - x0step
      sys%dw(:, i, :) = sk - s0step
    end do
    sys%q = 0.0_wp
    sys%r = 0.0_wp
    sys%dq = 0.0_wp
    sys%dr = 0.0_wp
    sys%ds = 0.0_wp
    do k = 1, nw
      sys%q(k, k) = theta(l%oq + k)
    end do
    do k = 1, ny
      sys%r(k, k) = theta(l%or + k)
    end do
    sys%s = reshape(theta(l%os + 1:l%os + nw*ny), [nw, ny])
    sys%r0 = sys%r
    sys%s0 = sys%s
    do k = 1, size(pm%iq)
      sys%dq(pm%iq(k), pm%iq(k), pm%cq(k)) = sys%dq(pm%iq(k), pm%iq(k), pm%cq(k)) + pm%wq(k)
    end do
    do k = 1, size(pm%ir)
      sys%dr(pm%ir(k), pm%ir(k), pm%cr(k)) = sys%dr(pm%ir(k), pm%ir(k), pm%cr(k)) + pm%wr(k)
    end do
    do k = 1, size(pm%is)
      i = pm%is(k) - 1
      sys%ds(mod(i, nw) + 1, i/nw + 1, pm%cs(k)) = sys%ds(mod(i, nw) + 1, i/nw + 1, pm%cs(k)) + &
                                                  pm%ws(k)
    end do
    allocate (sys%nz_phi(nf), sys%nz_w(nf), sys%nz_c(nf), sys%nz_q(nf), sys%nz_r(nf), &
              sys%nz_s(nf))
    do k = 1, nf
      sys%nz_phi(k) = any(sys%dphi(:, :, k) /= 0.0_wp)
      sys%nz_w(k) = any(sys%dw(:, :, k) /= 0.0_wp)
      sys%nz_c(k) = any(sys%dc(:, :, k) /= 0.0_wp)
      sys%nz_q(k) = any(sys%dq(:, :, k) /= 0.0_wp)
      sys%nz_r(k) = any(sys%dr(:, :, k) /= 0.0_wp)
      sys%nz_s(k) = any(sys%ds(:, :, k) /= 0.0_wp)
    end do
    status = MLID_OK
    msg = ''

  contains

    subroutine integrate(x, uh, sx)
      real(wp), intent(inout) :: x(:), sx(:, :)
      real(wp), intent(in) :: uh(:)
      real(wp) :: h
      type(rk_work_t) :: wk
      integer :: isub
      h = dt/o1%substeps
      do isub = 1, o1%substeps
        call rk4_step(m, theta(1:l%np), t(1), h, uh, uh, x, pm%im, pm%cm, pm%wm, wk, sx)
      end do
    end subroutine integrate

  end subroutine lti_setup

  !> Measurement update: B, B^-1, log|B|, K, P+ and their partials.
  subroutine cov_update(sys, cv, partials, status, msg)
    type(lti_t), intent(in) :: sys
    type(cov_t), intent(inout) :: cv
    logical, intent(in) :: partials
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: pct(size(cv%pm, 1), size(sys%c, 1)), dpct(size(cv%pm, 1), size(sys%c, 1))
    real(wp) :: ct(size(sys%c, 2), size(sys%c, 1))
    integer :: k, ierr

    status = MLID_OK
    msg = ''
    ct = transpose(sys%c)
    pct = matmul(cv%pm, ct)
    cv%b = matmul(sys%c, pct) + sys%r
    cv%b = 0.5_wp*(cv%b + transpose(cv%b))
    call chol_inverse(cv%b, cv%binv, cv%logdet, ierr)
    if (ierr /= 0) then
      status = MLID_ERR_SINGULAR
      msg = 'innovation covariance B = C P C'' + R is not positive definite'
      return
    end if
    cv%k = matmul(pct, cv%binv)
    cv%pp = cv%pm - matmul(cv%k, transpose(pct))
    cv%pp = 0.5_wp*(cv%pp + transpose(cv%pp))
    if (.not. partials) return
    do k = 1, size(cv%dpm, 3)
      dpct = matmul(cv%dpm(:, :, k), ct)
      if (sys%nz_c(k)) dpct = dpct + matmul(cv%pm, transpose(sys%dc(:, :, k)))
      cv%db(:, :, k) = matmul(sys%c, dpct)
      if (sys%nz_c(k)) cv%db(:, :, k) = cv%db(:, :, k) + matmul(sys%dc(:, :, k), pct)
      if (sys%nz_r(k)) cv%db(:, :, k) = cv%db(:, :, k) + sys%dr(:, :, k)
      cv%db(:, :, k) = 0.5_wp*(cv%db(:, :, k) + transpose(cv%db(:, :, k)))
      cv%dk(:, :, k) = matmul(dpct - matmul(cv%k, cv%db(:, :, k)), cv%binv)
      ! dP+ = dP- - dK (C P-) - K d(C P-), with C P- = pct'
      cv%dpp(:, :, k) = cv%dpm(:, :, k) - matmul(cv%dk(:, :, k), transpose(pct)) &
                        - matmul(cv%k, transpose(dpct))
      cv%dpp(:, :, k) = 0.5_wp*(cv%dpp(:, :, k) + transpose(cv%dpp(:, :, k)))
    end do
  end subroutine cov_update

  !> Time update: P- of the next sample from P+ (and the partials), with the
  !> products shared by all parameters formed once and zero partials skipped.
  subroutine cov_predict(sys, cv, partials)
    type(lti_t), intent(in) :: sys
    type(cov_t), intent(inout) :: cv
    logical, intent(in) :: partials
    integer :: nx, nw, ny, k
    real(wp) :: sb(size(sys%s, 1), size(sys%s, 2)), qt(size(sys%q, 1), size(sys%q, 1))
    real(wp) :: kst(size(cv%k, 1), size(sys%s, 1)), a(size(cv%pm, 1), size(cv%pm, 1))
    real(wp) :: phit(size(cv%pm, 1), size(cv%pm, 1)), ppt(size(cv%pm, 1), size(cv%pm, 1))
    real(wp) :: qwt(size(sys%q, 1), size(cv%pm, 1)), wt(size(sys%w, 2), size(cv%pm, 1))
    real(wp) :: dqt(size(sys%q, 1), size(sys%q, 1)), dkst(size(cv%k, 1), size(sys%s, 1))
    real(wp) :: da(size(cv%pm, 1), size(cv%pm, 1)), tmp(size(cv%pm, 1), size(cv%pm, 1))
    logical :: corr

    nx = size(cv%pm, 1)
    nw = size(sys%q, 1)
    ny = size(sys%s, 2)
    corr = any(sys%s /= 0.0_wp)
    phit = transpose(sys%phi)
    wt = transpose(sys%w)
    sb = matmul(sys%s, cv%binv)
    qt = sys%q - matmul(sb, transpose(sys%s))          ! Q - S B^-1 S'
    kst = matmul(cv%k, transpose(sys%s))                ! K S'
    ppt = matmul(cv%pp, phit)                           ! P+ Phi'
    qwt = matmul(qt, wt)                                ! Q~ W'
    cv%pm = matmul(sys%phi, ppt) + matmul(sys%w, qwt)
    if (corr) then
      a = matmul(matmul(sys%phi, kst), wt)              ! Phi K S' W'
      cv%pm = cv%pm - a - transpose(a)
    end if
    if (.not. partials) return
    do k = 1, size(cv%dpm, 3)
      tmp = matmul(sys%phi, matmul(cv%dpp(:, :, k), phit))
      if (sys%nz_phi(k)) then
        da = matmul(sys%dphi(:, :, k), ppt)
        tmp = tmp + da + transpose(da)
      end if
      if (sys%nz_w(k)) then
        da = matmul(sys%dw(:, :, k), qwt)
        tmp = tmp + da + transpose(da)
      end if
      if (corr .or. sys%nz_q(k) .or. sys%nz_s(k)) then
        dqt = sys%dq(:, :, k)
        if (corr .or. sys%nz_s(k)) dqt = dqt - matmul(sys%ds(:, :, k), transpose(sb)) &
                                   + matmul(matmul(sb, cv%db(:, :, k)), transpose(sb)) &
                                   - matmul(sb, transpose(sys%ds(:, :, k)))
        tmp = tmp + matmul(sys%w, matmul(dqt, wt))
      end if
      if (corr .or. sys%nz_s(k)) then
        dkst = matmul(cv%dk(:, :, k), transpose(sys%s)) + matmul(cv%k, transpose(sys%ds(:, :, k)))
        da = matmul(matmul(sys%phi, dkst), wt)
        if (sys%nz_phi(k)) da = da + matmul(matmul(sys%dphi(:, :, k), kst), wt)
        if (sys%nz_w(k)) da = da + matmul(matmul(sys%phi, kst), transpose(sys%dw(:, :, k)))
        tmp = tmp - da - transpose(da)
      end if
      cv%dpm(:, :, k) = tmp
    end do
  end subroutine cov_predict

  !> Iterate update and prediction from P = 0 until P(j|j-1) (and its
  !> partials) stop changing; leave the converged update in cv.
  subroutine steady_state(sys, cv, partials, status, msg)
    type(lti_t), intent(in) :: sys
    type(cov_t), intent(inout) :: cv
    logical, intent(in) :: partials
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: p0(:, :), dp0(:, :, :)
    integer :: it
    integer, parameter :: max_it = 100000

    do it = 1, max_it
      call cov_update(sys, cv, partials, status, msg)
      if (status /= MLID_OK) return
      p0 = cv%pm
      dp0 = cv%dpm
      call cov_predict(sys, cv, partials)
      if (maxval(abs(cv%pm - p0)) <= 1.0e-14_wp*max(tiny(1.0_wp), maxval(abs(cv%pm)))) then
        if (.not. partials) exit
        if (maxval(abs(cv%dpm - dp0)) <= 1.0e-12_wp*max(tiny(1.0_wp), maxval(abs(cv%dpm)))) exit
      end if
    end do
    if (it > max_it) then
      status = MLID_ERR_NOCONV
      msg = 'steady-state Kalman filter: the Riccati iteration did not converge'
      return
    end if
    call cov_update(sys, cv, partials, status, msg)
  end subroutine steady_state

  subroutine cov_alloc(cv, nx, ny, nf)
    type(cov_t), intent(out) :: cv
    integer, intent(in) :: nx, ny, nf
    allocate (cv%pm(nx, nx), cv%dpm(nx, nx, nf), cv%pp(nx, nx), cv%dpp(nx, nx, nf), &
              cv%b(ny, ny), cv%binv(ny, ny), cv%db(ny, ny, nf), cv%k(nx, ny), cv%dk(nx, ny, nf))
    cv%pm = 0.0_wp
    cv%dpm = 0.0_wp
    cv%pp = 0.0_wp
    cv%dpp = 0.0_wp
    cv%db = 0.0_wp
    cv%dk = 0.0_wp
  end subroutine cov_alloc

  !> Integrate x (and s) over sample interval j -> j+1 with the noise inputs
  !> held at what; sforce: constant forcing of the sensitivities.
  subroutine advance(m, theta, pm, t, u, opt, j, what, x, wk, s, sforce, us)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :)
    type(options_t), intent(in) :: opt
    integer, intent(in) :: j
    real(wp), intent(in) :: what(:)
    real(wp), intent(inout) :: x(:)
    type(rk_work_t), intent(inout) :: wk          !< the integration's work arrays (mlid_rk)
    real(wp), intent(inout), optional :: s(:, :)
    real(wp), intent(in), optional :: sforce(:, :)
    type(input_sens_t), intent(in), optional :: us
    real(wp) :: w(m%nw)

    w = 0.0_wp
    if (size(what) > 0) w = what
    call rk4_interval(m, theta(1:pm%l%np), t(j), t(j + 1), u(:, j), u(:, j + 1), w, opt%hold, &
                      opt%substeps, x, pm%im, pm%cm, pm%wm, wk, s, sforce, us)
  end subroutine advance

  !> As advance, for columns that no model parameter forces (Phi and W).
  subroutine advance_plain(m, theta, pm, t, u, opt, j, what, x, wk, s, sforce)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :)
    type(options_t), intent(in) :: opt
    integer, intent(in) :: j
    real(wp), intent(in) :: what(:)
    real(wp), intent(inout) :: x(:), s(:, :)
    type(rk_work_t), intent(inout) :: wk
    real(wp), intent(in) :: sforce(:, :)
    integer :: none(0)

    call rk4_interval(m, theta(1:pm%l%np), t(j), t(j + 1), u(:, j), u(:, j + 1), what, opt%hold, &
                      opt%substeps, x, none, none, [real(wp) ::], wk, s, sforce)
  end subroutine advance_plain

  !> Sensitivities of the initial state of segment iseg: a unit column for
  !> each of its free x0 entries.
  pure function initial_sensitivity(pm, iseg) result(s)
    type(param_map_t), intent(in) :: pm
    integer, intent(in) :: iseg
    real(wp) :: s(pm%l%nx, pm%nf)
    integer :: k, i
    s = 0.0_wp
    do k = 1, size(pm%ix0)
      i = pm%ix0(k) - (iseg - 1)*pm%l%nx
      if (i >= 1 .and. i <= pm%l%nx) s(i, pm%cx0(k)) = s(i, pm%cx0(k)) + pm%wx0(k)
    end do
  end function initial_sensitivity

  !> Whether sample j starts a segment (a manoeuvre); iseg counts them.
  logical function segment_starts(l, j, iseg)
    type(layout_t), intent(in) :: l
    integer, intent(in) :: j
    integer, intent(inout) :: iseg
    segment_starts = .false.
    if (iseg < l%nseg) segment_starts = l%seg(iseg + 1) == j
    if (segment_starts) iseg = iseg + 1
  end function segment_starts

  !> dy/dtheta at one sample of segment iseg: C s + dh/dp + its bias columns.
  subroutine output_sensitivity(m, theta, pm, t, x, u, s, dy, c, d, iseg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), t, x(:), u(:), s(:, :)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(out) :: dy(:, :), c(:, :), d(:, :)
    integer, intent(in) :: iseg
    integer :: k, i

    call m%h_jac(t, x, u, theta(1:pm%l%np), pm%im, c, d)
    dy = matmul(c, s)
    if (size(pm%im) > 0) then
      do k = 1, size(pm%im)
        dy(:, pm%cm(k)) = dy(:, pm%cm(k)) + pm%wm(k)*d(:, k)
      end do
    end if
    do k = 1, size(pm%ib)
      i = pm%ib(k) - (iseg - 1)*pm%l%ny
      if (i >= 1 .and. i <= pm%l%ny) dy(i, pm%cb(k)) = dy(i, pm%cb(k)) + pm%wb(k)
    end do
  end subroutine output_sensitivity

  subroutine diverged(t, status, msg)
    real(wp), intent(in) :: t
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    status = MLID_ERR_DIVERGED
    write (msg, '(a,g0.6,a)') 'simulation diverged: state non-finite at t = ', t, &
      ' (unstable model or parameters far off)'
  end subroutine diverged

end module mlid_filter
