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
!>   them: with opt%partials it differences whole filter runs instead.
!>   With opt%steady a nonlinear model's states still follow the nonlinear
!>   model, but K and B are the steady state of its linearisation about the
!>   first initial state and input sample (linearise_once), as in the
!>   textbook's filter error for nonlinear systems (Jategaonkar ch. 5, ml_fem).
!>
!> This file holds the interface, the types the filter keeps, and the
!> recursions along the record (oe_predict, kf_innovations) with the steps
!> they take at every sample and every manoeuvre: those stay private
!> procedures of one file, for the compiler inlines and specialises only
!> those (a procedure of a submodule is a global symbol, which the core,
!> compiled -fPIC, may not inline).  The submodules: mlid_filter_covariance
!> (the covariance updates and their partials, the noise over an interval,
!> the steady-state gain) and mlid_filter_system (what stays fixed along a
!> record, set up once per run).
module mlid_filter
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_DIVERGED, MLID_ERR_INPUT, MLID_ERR_INTERRUPTED, &
                        MLID_ERR_MEMORY, first_failure
  use mlid_linalg, only: expm_work_t
  use mlid_models, only: model_t, layout_t, NZ_HROWS
  use mlid_options, only: options_t
  use mlid_params, only: param_map_t, segment_map, input_delays, output_delays, stabilized
  use mlid_rk, only: rk4_interval, input_sens_t, rk_work_t, rk_work_size, small_product, &
                    product_7x4_add, product_7x4_add_tail, past_states
  use mlid_delay, only: delay_outputs, delay_check
  use mlid_lti_predict, only: lti_exact, lti_segment
  use mlid_interrupt, only: check_interrupt, POLL_MASK
  use mlid_memory, only: no_memory
  use mlid_text, only: itoa
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
    !> Work arrays of cov_update and cov_predict (nx x ny, nx x nx, ny x ny,
    !> ny x nx), sized by cov_alloc: nothing is allocated per sample.
    real(wp), allocatable :: ct(:, :), pct(:, :), dpct(:, :), gb(:, :), xy(:, :)
    real(wp), allocatable :: phit(:, :), ppt(:, :), a(:, :), da(:, :), tmp(:, :), x1(:, :), &
                             x2(:, :)
    real(wp), allocatable :: yy(:, :), yx(:, :)
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
    !> The process noise as it reaches the state over an interval, W Q W'
    !> (held noise) or the integral of the continuous noise's covariance
    !> (noise_reach), its correlation G = W S with the measurement noise,
    !> and their partials.
    real(wp), allocatable :: wqw(:, :), dwqw(:, :, :), gs(:, :), dgs(:, :, :)
    logical, allocatable :: nz_wqw(:), nz_gs(:)
    real(wp) :: dt = -1.0_wp
    !> Work arrays of noise_reach and output_noise (nw x nx, nx x nx, nw x ny,
    !> ny x ny; van_loan's 2nx x 2nx and its exponential's), sized by lti_setup.
    real(wp), allocatable :: qw(:, :), gqg(:, :), qd(:, :), ryy(:, :), vm(:, :), ve(:, :)
    type(expm_work_t) :: ew
  end type lti_t

  !> Procedures of the submodules that other files call (private, as the rest).
  interface

    ! in mlid_filter_system

    !> C, Phi, W, Q, R, S and their partials: what stays fixed along the record.
    module subroutine lti_setup(m, theta, pm, t, u, opt, sys, status, msg)
      class(model_t), intent(in) :: m
      real(wp), intent(in) :: theta(:)
      type(param_map_t), intent(in) :: pm
      real(wp), intent(in) :: t(:), u(:, :)
      type(options_t), intent(in) :: opt
      type(lti_t), intent(out) :: sys
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
    end subroutine lti_setup

    ! in mlid_filter_covariance

    !> The effective R and S of outputs that carry the process noise.
    module subroutine output_noise(sys, dhw, code, status, msg)
      type(lti_t), intent(inout) :: sys
      real(wp), intent(in) :: dhw(:, :)
      integer, intent(in) :: code       !< opt%process_noise
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
    end subroutine output_noise

    !> Measurement update: B, B^-1, log|B|, K, P+ and their partials.
    module subroutine cov_update(sys, cv, partials, status, msg)
      type(lti_t), intent(in) :: sys
      type(cov_t), intent(inout) :: cv
      logical, intent(in) :: partials
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
    end subroutine cov_update

    !> Time update: P- of the next sample (and its partials).
    module subroutine cov_predict(sys, cv, partials)
      type(lti_t), intent(in) :: sys
      type(cov_t), intent(inout) :: cv
      logical, intent(in) :: partials
    end subroutine cov_predict

    !> The process noise as it reaches the state over an interval; G = W S.
    module subroutine noise_reach(sys, code, a, status, msg)
      type(lti_t), intent(inout) :: sys
      integer, intent(in) :: code
      real(wp), intent(in) :: a(:, :)
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
    end subroutine noise_reach

    !> Van Loan's matrix [-A, v; 0, A'] h (2n x 2n).
    pure module subroutine van_loan_matrix(a, v, h, mh)
      real(wp), intent(in) :: a(:, :), v(:, :), h
      real(wp), intent(out) :: mh(:, :)
    end subroutine van_loan_matrix

    !> The steady-state P(j|j-1) and its update (B, K, P+, partials).
    module subroutine steady_state(sys, cv, partials, status, msg)
      type(lti_t), intent(in) :: sys
      type(cov_t), intent(inout) :: cv
      logical, intent(in) :: partials
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
    end subroutine steady_state

    !> The covariances and their work arrays, sized once per run.
    module subroutine cov_alloc(cv, nx, ny, nf)
      type(cov_t), intent(out) :: cv
      integer, intent(in) :: nx, ny, nf
    end subroutine cov_alloc

  end interface

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

  !> A linear time-invariant model goes to mlid_lti_predict where it gives
  !> the same results up to rounding (lti_exact); else oe_segment on the
  !> model with the inputs that keep one value over the segment folded in (model_t%fold_inputs), and with sensitivities only
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

    if (lti_exact(m, theta, pm, t, j0, j1)) then     ! a linear model: its step is a matrix
      call lti_segment(m, theta, pm, t, u, opt, iseg, j0, j1, initial_sensitivity(pm, iseg), &
                       yhat, status, dy, xhist)
      msg = ''
      if (status == MLID_ERR_INTERRUPTED) call check_interrupt(status, msg)   ! its message
      if (status == MLID_ERR_MEMORY) call no_memory('the states of '//itoa(j1 - j0 + 1)// &
                                                    ' samples', real(m%nx, wp)*(j1 - j0 + 1), &
                                                    status, msg)
      if (status /= MLID_ERR_DIVERGED) return        ! else diverged: the RK4 path says where
    end if
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
      allocate (dyk(m%ny, pk%nf, size(t)), stat=i)
      if (i /= 0) then
        call no_memory('the sensitivities of '//itoa(size(t))//' samples x '//itoa(pk%nf)// &
          ' parameters', real(m%ny, wp)*pk%nf*size(t), status, msg)
        return
      end if
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
  !> A free K (filter_params = 'gain', report eq. 4.19) adds dK (z - yhat)
  !> to its own column.
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
      stab = stabilized(theta, l) .or. size(pm%ik) > 0
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
    !> du(k, j): how moving input delay k moves its input at sample j.  The
    !> model is evaluated once at each sample for the outputs and for the
    !> first stage of the step that starts there (same t, x and u, the noise
    !> zero), unless the stabilizing gain moves x in between.  Every work
    !> array is allocated here, once per segment.
    subroutine integrate(uu, du)
      real(wp), intent(in) :: uu(:, :)
      real(wp), intent(in), optional :: du(:, :)
      real(wp), allocatable :: s(:, :), c(:, :), d(:, :), hu(:, :), ue(:), w0(:)
      type(input_sens_t) :: us
      type(rk_work_t) :: wk
      real(wp) :: x(m%nx)
      integer :: j, k, np
      integer, allocatable :: frow(:), hrow(:, :)
      logical :: tail
      logical :: step

      np = pm%l%np
      allocate (ue(m%nu + m%nw), w0(m%nw))
      w0 = 0.0_wp
      ue(m%nu + 1:) = w0                   ! the stage's inputs: no process noise in output error
      if (present(dy)) then
        allocate (c(m%ny, m%nx), d(m%ny, size(pm%im)), hu(m%ny, m%nu), frow(size(pm%im)), &
                  hrow(NZ_HROWS, size(pm%im)))
        call m%param_rows(pm%im, frow, hrow)    ! once per segment, for output_rows
        tail = past_states(hrow)
      end if
      x = theta(pm%l%ox0 + (iseg - 1)*m%nx + 1:pm%l%ox0 + iseg*m%nx)
      if (present(dy)) then
        s = initial_sensitivity(pm, iseg)
        call rk_work_size(wk, m%nx, pm%nf, size(pm%im), m%nu, m%nu + m%nw, m, pm%im)
      else
        call rk_work_size(wk, m%nx, 0, size(pm%im), m%nu, m%nu + m%nw)
      end if
      if (present(du)) us = input_sens_t(pm%iu, pm%cu, du(:, j0), du(:, j0))
      do j = j0, j1
        if (iand(j, POLL_MASK) == 0) then
          call check_interrupt(status, msg)
          if (status /= MLID_OK) return
        end if
        if (j > j0) then
          if (present(dy) .and. present(du)) then
            us%d0 = du(:, j - 1)
            us%d1 = du(:, j)
            call advance(m, theta, pm, t, uu, opt, j - 1, w0, x, wk, s, us=us)
          else if (present(dy)) then
            call advance(m, theta, pm, t, uu, opt, j - 1, w0, x, wk, s)
          else
            call advance(m, theta, pm, t, uu, opt, j - 1, w0, x, wk)
          end if
          if (.not. all(ieee_is_finite(x))) then
            call diverged(t(j), status, msg)
            return
          end if
        end if
        if (present(xhist)) xhist(:, j) = x
        step = j < j1 .and. .not. stab .and. m%nx > 0
        ue(1:m%nu) = uu(:, j)
        if (present(dy) .and. step) then
          call m%eval(t(j), x, ue, theta(1:np), pm%im, xdot=wk%k(:, 1), a=wk%a, b=wk%b, &
                      y=yhat(:, j), c=c, d=d)
        else if (present(dy)) then
          call m%eval(t(j), x, ue, theta(1:np), pm%im, y=yhat(:, j), c=c, d=d)
        else if (step) then
          call m%eval(t(j), x, ue, theta(1:np), pm%im, xdot=wk%k(:, 1), y=yhat(:, j))
        else
          call m%eval(t(j), x, ue, theta(1:np), pm%im, y=yhat(:, j))
        end if
        wk%first_known = step
        yhat(:, j) = yhat(:, j) + theta(pm%l%obias + (iseg - 1)*m%ny + 1:pm%l%obias + iseg*m%ny)
        if (present(dy)) then
          call output_rows(pm, s, c, d, iseg, dy(:, :, j), tail)
          if (present(du)) then
            call m%dhdu(t(j), x, uu(:, j), theta(1:np), hu)
            do k = 1, size(pm%iu)
              dy(:, pm%cu(k), j) = dy(:, pm%cu(k), j) + hu(:, pm%iu(k))*du(k, j)
            end do
          end if
        end if
        if (.not. stab) cycle
        x = x + matmul(gain, z(:, j) - yhat(:, j))
        if (present(dy)) then
          s = s - matmul(gain, dy(:, :, j))
          do k = 1, size(pm%ik)            ! K(i, c): column-major in block stab
            associate (ix => mod(pm%ik(k) - 1, m%nx) + 1, iy => (pm%ik(k) - 1)/m%nx + 1)
              s(ix, pm%ck(k)) = s(ix, pm%ck(k)) + pm%wk(k)*(z(iy, j) - yhat(iy, j))
            end associate
          end do
        end if
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
  !> dnu(ny, nf, nt) and, with opt%partials, db(ny, ny, nf, nt); with
  !> opt%steady B is the same at every sample and db holds it once
  !> (db(:, :, :, 1)).
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
    ! every work array sized here, once per run: nothing is allocated per sample
    real(wp), allocatable :: s(:, :), c(:, :), d(:, :), what(:), dwhat(:, :), ks(:, :), gdw(:, :)
    real(wp), allocatable :: sj(:, :), fj(:, :)
    real(wp) :: x(m%nx), dhw(m%ny, m%nw), sb(m%nw, m%ny), ax(m%nx, m%nx), bnu(m%ny)
    real(wp) :: ue(m%nu + m%nw), kn(m%nx), vw(m%nw), vw2(m%nw), vy(m%ny)
    type(rk_work_t) :: wk
    integer :: j, k, nf, nx, nw, ns, iseg
    integer :: none(0)
    logical :: sens, partials, ekf, relin
    logical :: corr      !< a measurement noise correlated with the process noise: S or dS /= 0

    status = MLID_OK
    msg = ''
    l = pm%l
    nf = pm%nf
    sens = present(dnu)
    ekf = .not. m%linear
    relin = ekf .and. .not. opt%steady      ! linearise every interval (the EKF proper)
    partials = sens .and. opt%partials
    nx = l%nx
    nw = l%nw
    call lti_setup(m, theta, pm, t, u, opt, sys, status, msg)
    if (status /= MLID_OK) return
    ns = merge(nf, 0, sens)
    if (relin) then
      ! columns: the parameter sensitivities (if wanted), then Phi, then W
      allocate (sj(nx, ns + nx + nw), fj(nx, ns + nx + nw))
      if (sens) then
        call rk_work_size(wk, nx, ns + nx + nw, size(pm%im), m%nu, m%nu + nw, m, pm%im)
      else
        call rk_work_size(wk, nx, ns + nx + nw, 0, m%nu, m%nu + nw)
      end if
    else if (sens) then           ! the forcing's structure, for every interval's steps
      call rk_work_size(wk, nx, nf, size(pm%im), m%nu, m%nu + nw, m, pm%im)
    end if
    call cov_alloc(cv, l%nx, l%ny, nf)
    allocate (s(nx, nf), c(l%ny, l%nx), d(l%ny, size(pm%im)), what(l%nw), dwhat(l%nw, nf), &
              ks(nx, nf), gdw(nx, nf))
    if (opt%steady .and. ekf) then
      ! The textbook's filter error for nonlinear systems (ml_fem): the states
      ! follow the nonlinear model, the gain is the steady state of the model
      ! linearised once, about the start of the record; it saves the EKF's
      ! per-interval Jacobian integration and covariance steps.
      call linearise_once(m, theta, pm, t, u, opt, sys, status, msg)
      if (status == MLID_OK) call steady_state(sys, cv, partials, status, msg)
      if (status /= MLID_OK) then
        msg = trim(msg)//' (steady-state gain of the nonlinear model linearised about x0 and '// &
              'the first input sample)'
        return
      end if
    else if (opt%steady) then
      call steady_state(sys, cv, partials, status, msg)
      if (status /= MLID_OK) return
    end if
    corr = any(sys%s /= 0.0_wp) .or. any(sys%nz_s)   ! (a nonlinear model's steady S included)
    iseg = 0

    do j = 1, size(t)
      if (iand(j, POLL_MASK) == 0) then
        call check_interrupt(status, msg)
        if (status /= MLID_OK) return
      end if
      if (segment_starts(l, j, iseg)) then
        ! each manoeuvre from its own (known) initial state: P = 0
        x = theta(l%ox0 + (iseg - 1)*l%nx + 1:l%ox0 + iseg*l%nx)
        s(:, :) = initial_sensitivity(pm, iseg)
        what = 0.0_wp
        dwhat = 0.0_wp
        if (.not. opt%steady) call initial_covariance(theta, pm, cv)
      else
        ue(1:m%nu) = u(:, j - 1)          ! the model's inputs where the interval starts
        ue(m%nu + 1:) = what
        if (relin) then
          ! the interval from x(j-1|j-1), eq. 4.27: Phi and W integrated with
          ! the state (and its sensitivities) as extra columns; df/dx and the
          ! first RK4 stage from one evaluation of the model
          call m%dfdw(t(j - 1), x, ue, theta(1:l%np), sys%g)
          if (sens) then
            call m%eval(t(j - 1), x, ue, theta(1:l%np), pm%im, xdot=wk%k(:, 1), a=wk%a, b=wk%b)
          else
            call m%eval(t(j - 1), x, ue, theta(1:l%np), none, xdot=wk%k(:, 1), a=wk%a, b=wk%b)
          end if
          wk%first_known = .true.
          if (opt%process_noise /= 0) ax = wk%a
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
            s(:, :) = sj(:, 1:nf)
          else          ! no parameter columns: nothing may force them
            call advance_plain(m, theta, pm, t, u, opt, j - 1, what, x, wk, sj, fj)
          end if
          sys%phi(:, :) = sj(:, ns + 1:ns + nx)
          sys%w(:, :) = sj(:, ns + nx + 1:)
          call noise_reach(sys, opt%process_noise, ax, status, msg)
          if (status /= MLID_OK) return
        else if (sens) then
          ! a nonlinear model's df/dw where the interval starts, as the EKF takes it
          if (ekf) call m%dfdw(t(j - 1), x, ue, theta(1:l%np), sys%g)
          gdw(:, :) = matmul(sys%g, dwhat)
          call advance(m, theta, pm, t, u, opt, j - 1, what, x, wk, s, gdw)
        else
          call advance(m, theta, pm, t, u, opt, j - 1, what, x, wk)
        end if
        if (.not. all(ieee_is_finite(x))) then
          call diverged(t(j), status, msg)
          return
        end if
        if (.not. opt%steady) call cov_predict(sys, cv, partials)
      end if
      ! the model once at x(j|j-1): the outputs, C = dh/dx (the EKF's, every
      ! sample) and dh/dp (for the sensitivities)
      if (relin .and. sens) then
        call m%eval(t(j), x, u(:, j), theta(1:l%np), pm%im, y=yhat(:, j), c=sys%c, d=d)
      else if (relin) then
        call m%eval(t(j), x, u(:, j), theta(1:l%np), none, y=yhat(:, j), c=sys%c)
      else if (sens) then
        call m%eval(t(j), x, u(:, j), theta(1:l%np), pm%im, y=yhat(:, j), c=c, d=d)
      else
        call m%eval(t(j), x, u(:, j), theta(1:l%np), none, y=yhat(:, j))
      end if
      if (relin) then
        call m%dhdw(t(j), x, u(:, j), theta(1:l%np), dhw)
        call output_noise(sys, dhw, opt%process_noise, status, msg)
        if (status /= MLID_OK) return
        if (any(dhw /= 0.0_wp)) corr = .true.
      end if
      if (.not. opt%steady) then
        call cov_update(sys, cv, partials, status, msg)
        if (status /= MLID_OK) then
          write (msg, '(a,g0.6,a)') trim(msg)//' at t = ', t(j)
          return
        end if
      end if
      yhat(:, j) = yhat(:, j) + theta(l%obias + (iseg - 1)*l%ny + 1:l%obias + iseg*l%ny)
      nu(:, j) = y(:, j) - yhat(:, j)
      binv(:, :, j) = cv%binv
      logdet(j) = cv%logdet
      if (present(bhist)) bhist(:, :, j) = cv%b
      if (sens) then                ! d nu = -(C dx(j|j-1) + dh/dp + d bias), eq. 4.31
        if (relin) then
          call output_rows(pm, s, sys%c, d, iseg, dnu(:, :, j), .false.)
        else
          call output_rows(pm, s, c, d, iseg, dnu(:, :, j), .false.)
        end if
        dnu(:, :, j) = -dnu(:, :, j)
      end if
      ! x(j|j) and its sensitivities (eq. 4.36), and the held-noise estimate for
      ! the next interval (none without a correlation S: skipped, it is most
      ! of a sample's work)
      kn = matmul(cv%k, nu(:, j))
      x = x + kn
      if (corr) then
        sb = matmul(sys%s, cv%binv)
        bnu = matmul(cv%binv, nu(:, j))
        what(:) = matmul(sb, nu(:, j))
      end if
      if (sens) then
        ks(:, :) = matmul(cv%k, dnu(:, :, j))
        s(:, :) = s + ks
        if (corr) dwhat(:, :) = matmul(sb, dnu(:, :, j))
        if (partials) then
          if (.not. opt%steady) db(:, :, :, j) = cv%db
          if (opt%steady .and. j == 1) db(:, :, :, 1) = cv%db
          do k = 1, nf
            kn = matmul(cv%dk(:, :, k), nu(:, j))
            s(:, k) = s(:, k) + kn
          end do
          do k = 1, merge(nf, 0, corr)
            vw = matmul(sys%ds(:, :, k), bnu)
            vy = matmul(cv%db(:, :, k), bnu)
            vw2 = matmul(sb, vy)
            dwhat(:, k) = dwhat(:, k) + vw - vw2
          end do
        end if
      end if
    end do

  end subroutine kf_innovations

  !> For the steady-state gain of a nonlinear model: Phi, W, V and G
  !> (noise_reach) of the interval from the first sample, and C and the
  !> effective R and S there, all about the first manoeuvre's initial state,
  !> u(:, 1) and zero noise; the EKF's linearisation of one interval.
  !> Redone at each evaluation of the cost, so the gain follows the
  !> parameters (and x0) as the textbook's ml_fem has it.
  subroutine linearise_once(m, theta, pm, t, u, opt, sys, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :)
    type(options_t), intent(in) :: opt
    type(lti_t), intent(inout) :: sys
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: x0(m%nx), x(m%nx), w0(m%nw), ax(m%nx, m%nx), dhw(m%ny, m%nw)
    real(wp) :: sj(m%nx, m%nx + m%nw), fj(m%nx, m%nx + m%nw)
    type(rk_work_t) :: wk
    integer :: k, nx, np

    nx = m%nx
    np = pm%l%np
    x0 = theta(pm%l%ox0 + 1:pm%l%ox0 + nx)
    w0 = 0.0_wp
    ax = 0.0_wp
    call m%dfdw(t(1), x0, [u(:, 1), w0], theta(1:np), sys%g)
    if (opt%process_noise /= 0) call m%dfdx(t(1), x0, [u(:, 1), w0], theta(1:np), ax)
    sj = 0.0_wp
    fj = 0.0_wp
    do k = 1, nx
      sj(k, k) = 1.0_wp
    end do
    fj(:, nx + 1:) = sys%g
    x = x0
    call advance_plain(m, theta, pm, t, u, opt, 1, w0, x, wk, sj, fj)
    sys%phi = sj(:, 1:nx)
    sys%w = sj(:, nx + 1:)
    call m%dhdx(t(1), x0, u(:, 1), theta(1:np), sys%c)
    call m%dhdw(t(1), x0, u(:, 1), theta(1:np), dhw)
    if (.not. (all(ieee_is_finite(sj)) .and. all(ieee_is_finite(sys%c)) .and. &
               all(ieee_is_finite(ax)) .and. all(ieee_is_finite(dhw)))) then
      status = MLID_ERR_DIVERGED
      msg = 'the linearisation is not finite'
      return
    end if
    call output_noise(sys, dhw, opt%process_noise, status, msg)
    if (status == MLID_OK) call noise_reach(sys, opt%process_noise, ax, status, msg)
  end subroutine linearise_once

  !> P(1|0) = diag(p0) at the start of a manoeuvre (the report's P(0|0)
  !> carried to the first sample; zero: a known initial state), and its
  !> partials: a unit entry for each free p0.
  pure subroutine initial_covariance(theta, pm, cv)
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    type(cov_t), intent(inout) :: cv
    integer :: i, k
    cv%pm = 0.0_wp
    cv%dpm = 0.0_wp
    do i = 1, pm%l%nx
      cv%pm(i, i) = theta(pm%l%op0 + i)
    end do
    do k = 1, size(pm%ip0)
      i = pm%ip0(k)
      cv%dpm(i, i, pm%cp0(k)) = cv%dpm(i, i, pm%cp0(k)) + pm%wp0(k)
    end do
  end subroutine initial_covariance

  !> Integrate x (and s) over sample interval j -> j+1 with the noise inputs
  !> held at what (nw values); sforce: constant forcing of the sensitivities.
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

    call rk4_interval(m, theta(1:pm%l%np), t(j), t(j + 1), u(:, j), u(:, j + 1), what, opt%hold, &
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
    real(wp) :: nothing(0)

    call rk4_interval(m, theta(1:pm%l%np), t(j), t(j + 1), u(:, j), u(:, j + 1), what, opt%hold, &
                      opt%substeps, x, none, none, nothing, wk, s, sforce)
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

  !> dy = c s + d (into the columns of the model parameters) + the bias
  !> columns of segment iseg: the output sensitivities from c = dh/dx and
  !> d = dh/dp(pm%im); tail: d's first four rows are zero (param_rows).
  subroutine output_rows(pm, s, c, d, iseg, dy, tail)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in), contiguous :: s(:, :), c(:, :), d(:, :)
    integer, intent(in) :: iseg
    real(wp), intent(out) :: dy(:, :)
    logical, intent(in) :: tail
    integer :: k, i

    if (size(c, 1) == 7 .and. size(c, 2) == 4 .and. leading(pm%cm)) then
      ! seven outputs of four states, the model parameters the first
      ! columns: d's added as each column of C S is made (the same sums),
      ! its last three rows alone when the others are zero
      if (tail) then
        call product_7x4_add_tail(size(s, 2), size(pm%im), c, s, d, pm%wm, dy)
      else
        call product_7x4_add(size(s, 2), size(pm%im), c, s, d, pm%wm, dy)
      end if
    else
      call small_product(c, s, dy)
      do k = 1, size(pm%im)
        dy(:, pm%cm(k)) = dy(:, pm%cm(k)) + pm%wm(k)*d(:, k)
      end do
    end if
    do k = 1, size(pm%ib)
      i = pm%ib(k) - (iseg - 1)*pm%l%ny
      if (i >= 1 .and. i <= pm%l%ny) dy(i, pm%cb(k)) = dy(i, pm%cb(k)) + pm%wb(k)
    end do
  end subroutine output_rows

  !> Whether a(k) = k for every k (the columns 1, 2, .., each once).
  pure logical function leading(a)
    integer, intent(in) :: a(:)
    integer :: k
    leading = .false.
    do k = 1, size(a)
      if (a(k) /= k) return
    end do
    leading = .true.
  end function leading

  subroutine diverged(t, status, msg)
    real(wp), intent(in) :: t
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    status = MLID_ERR_DIVERGED
    write (msg, '(a,g0.6,a)') 'simulation diverged: state non-finite at t = ', t, &
      ' (unstable model or parameters far off)'
  end subroutine diverged

end module mlid_filter
