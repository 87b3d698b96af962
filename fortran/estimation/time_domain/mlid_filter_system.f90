!> What the Kalman filter holds fixed along a record (mlid_filter), set up
!> once per run: C, Phi, W, Q, R, S of a linear model and their partials
!> (lti_setup), and the partials of the process noise as it reaches the
!> state (noise_reach_partials, with the derivative of Van Loan's
!> exponential for continuous noise).
submodule (mlid_filter) mlid_filter_system
  use mlid_linalg, only: expm, expm_work_size
  use mlid_rk, only: rk4_step
  implicit none

contains

  !> Everything the filter holds fixed along the record (linear models):
  !> C, Phi, W = held-noise transition, Q, R, S and their partials.
  module procedure lti_setup
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
    allocate (sys%qw(nw, nx), sys%gqg(nx, nx), sys%qd(nw, ny), sys%ryy(ny, ny), &
              sys%vm(2*nx, 2*nx), sys%ve(2*nx, 2*nx))
    call expm_work_size(sys%ew, 2*nx)
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
    do k = 1, nw                   ! continuous_sd: q is a standard deviation
      sys%q(k, k) = merge(theta(l%oq + k)**2, theta(l%oq + k), opt%process_noise == 2)
    end do
    do k = 1, ny
      sys%r(k, k) = theta(l%or + k)
    end do
    sys%s = reshape(theta(l%os + 1:l%os + nw*ny), [nw, ny])
    sys%r0 = sys%r
    sys%s0 = sys%s
    do k = 1, size(pm%iq)
      i = pm%iq(k)
      sys%dq(i, i, pm%cq(k)) = sys%dq(i, i, pm%cq(k)) + pm%wq(k)* &
                               merge(2.0_wp*theta(l%oq + i), 1.0_wp, opt%process_noise == 2)
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
    if (opt%process_noise /= 0 .and. (any(sys%s /= 0.0_wp) .or. any(sys%nz_s))) then
      msg = 'the cross-covariance s of process and measurement noise needs held noise, '// &
            'process_noise = ''held'''
      return
    end if
    allocate (sys%wqw(nx, nx), sys%gs(nx, ny))
    if (m%linear) then
      call noise_reach(sys, opt%process_noise, a, status, msg)
      if (status /= MLID_OK) return
      call noise_reach_partials(m, theta, pm, t, opt%process_noise, a, sys, status, msg)
      if (status /= MLID_OK) return
    else                            ! set per interval (kf_innovations); no analytic partials
      allocate (sys%dwqw(nx, nx, nf), sys%dgs(nx, ny, nf))
      sys%dwqw = 0.0_wp
      sys%dgs = 0.0_wp
      sys%nz_wqw = [(.false., k=1, nf)]
      sys%nz_gs = sys%nz_wqw
    end if
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

  end procedure lti_setup

  !> The partials of V and G (noise_reach) for a linear model.  Continuous
  !> noise needs those of A and Gamma: df/dp at unit states (unit noise)
  !> less df/dp at zero, the model being linear.
  subroutine noise_reach_partials(m, theta, pm, t, code, a, sys, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), t(:), a(:, :)
    type(param_map_t), intent(in) :: pm
    integer, intent(in) :: code
    type(lti_t), intent(inout) :: sys
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: da(m%nx, m%nx, pm%nf), dgam(m%nx, m%nw, pm%nf), dv(m%nx, m%nx, pm%nf)
    real(wp) :: b0(m%nx, size(pm%im)), b1(m%nx, size(pm%im)), e(m%nx), ua(m%nu + m%nw)
    real(wp) :: y(m%nx, m%nx)
    integer :: i, k, nf
    logical :: nz(pm%nf)

    nf = pm%nf
    status = MLID_OK
    msg = ''
    allocate (sys%dwqw(m%nx, m%nx, nf), sys%dgs(m%nx, m%ny, nf), sys%nz_wqw(nf), sys%nz_gs(nf))
    if (code == 0) then
      do k = 1, nf
        sys%dwqw(:, :, k) = 0.0_wp
        if (sys%nz_w(k)) then
          y = matmul(sys%dw(:, :, k), matmul(sys%q, transpose(sys%w)))
          sys%dwqw(:, :, k) = y + transpose(y)
        end if
        if (sys%nz_q(k)) sys%dwqw(:, :, k) = sys%dwqw(:, :, k) + &
                                             matmul(sys%w, matmul(sys%dq(:, :, k), transpose(sys%w)))
        sys%dgs(:, :, k) = matmul(sys%dw(:, :, k), sys%s) + matmul(sys%w, sys%ds(:, :, k))
      end do
    else
      e = 0.0_wp
      ua = 0.0_wp
      da = 0.0_wp
      dgam = 0.0_wp
      call m%dfdp(t(1), e, ua, theta(1:pm%l%np), pm%im, b0)
      do i = 1, m%nx + m%nw
        e = 0.0_wp
        ua = 0.0_wp
        if (i <= m%nx) e(i) = 1.0_wp
        if (i > m%nx) ua(m%nu + i - m%nx) = 1.0_wp
        call m%dfdp(t(1), e, ua, theta(1:pm%l%np), pm%im, b1)
        do k = 1, size(pm%im)
          if (i <= m%nx) da(:, i, pm%cm(k)) = da(:, i, pm%cm(k)) + pm%wm(k)*(b1(:, k) - b0(:, k))
          if (i > m%nx) dgam(:, i - m%nx, pm%cm(k)) = dgam(:, i - m%nx, pm%cm(k)) + &
                                                        pm%wm(k)*(b1(:, k) - b0(:, k))
        end do
      end do
      do k = 1, nf
        y = matmul(dgam(:, :, k), matmul(sys%q, transpose(sys%g)))
        dv(:, :, k) = y + transpose(y) + matmul(sys%g, matmul(sys%dq(:, :, k), transpose(sys%g)))
        nz(k) = any(da(:, :, k) /= 0.0_wp) .or. any(dv(:, :, k) /= 0.0_wp)
      end do
      call van_loan_partials(a, matmul(sys%g, matmul(sys%q, transpose(sys%g))), sys%dt, da, dv, &
                             nz, sys%dwqw, status, msg)
      sys%dgs = 0.0_wp
    end if
    do k = 1, nf
      sys%nz_wqw(k) = any(sys%dwqw(:, :, k) /= 0.0_wp)
      sys%nz_gs(k) = any(sys%dgs(:, :, k) /= 0.0_wp)
    end do
  end subroutine noise_reach_partials

  !> The partials of van_loan's qd for each k with nz(k) (zero for the
  !> others), from the derivative of the exponential: the upper right block
  !> of e^{[M, dM; 0, M] h} is d(e^{M h}).
  subroutine van_loan_partials(a, v, h, da, dv, nz, dqd, status, msg)
    real(wp), intent(in) :: a(:, :), v(:, :), h, da(:, :, :), dv(:, :, :)
    logical, intent(in) :: nz(:)
    real(wp), intent(out) :: dqd(:, :, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: big(4*size(a, 1), 4*size(a, 1)), eb(4*size(a, 1), 4*size(a, 1))
    real(wp) :: e(2*size(a, 1), 2*size(a, 1)), de(2*size(a, 1), 2*size(a, 1))
    integer :: n, k, info
    n = size(a, 1)
    dqd = 0.0_wp
    status = MLID_OK
    msg = ''
    big = 0.0_wp
    call van_loan_matrix(a, v, h, big(1:2*n, 1:2*n))
    big(2*n + 1:, 2*n + 1:) = big(1:2*n, 1:2*n)
    do k = 1, size(nz)
      if (.not. nz(k)) cycle
      call van_loan_matrix(da(:, :, k), dv(:, :, k), h, big(1:2*n, 2*n + 1:))
      call expm(big, eb, info)
      if (info /= 0) then
        status = MLID_ERR_DIVERGED
        msg = 'continuous process noise: the partials of its covariance are not finite'
        return
      end if
      e = eb(1:2*n, 1:2*n)
      de = eb(1:2*n, 2*n + 1:)
      dqd(:, :, k) = matmul(transpose(de(n + 1:, n + 1:)), e(1:n, n + 1:)) + &
                     matmul(transpose(e(n + 1:, n + 1:)), de(1:n, n + 1:))
      dqd(:, :, k) = 0.5_wp*(dqd(:, :, k) + transpose(dqd(:, :, k)))
    end do
  end subroutine van_loan_partials

end submodule mlid_filter_system
