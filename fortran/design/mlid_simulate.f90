!> Data generation: the model along a record with process noise held over
!> each sample interval and measurement noise, drawn together from a seeded
!> generator with the covariances in theta:
!>
!>     [w_j; v_j] ~ N(0, [[Q, S], [S', R]])
!>
!> w_j drives the interval that follows t_j and v_j corrupts y(t_j), so the
!> two are correlated forward in time (report §5.1.5), as the filter assumes.
!> Outputs that carry the process noise (dh/dw, accelerometers) get
!> (dh/dw) w_j with the forward timing, or (dh/dw) w_(j-1), the noise of the
!> interval before the sample, with the backward timing (timing = 1; at the
!> first sample a draw of its own).
module mlid_simulate
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_DIVERGED
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_linalg, only: psd_factor
  use mlid_models, only: model_t, layout_t, model_layout
  use mlid_params, only: stabilized, param_map_t, param_map_create, no_ties
  use mlid_lti_predict, only: lti_exact, lti_segment
  use mlid_options, only: options_t
  use mlid_delay, only: delay_outputs, delay_check
  use mlid_rk, only: rk4_interval, rk_work_t
  use mlid_random, only: rng_t, rng_seed, rng_normal
  use mlid_setup, only: setup
  use mlid_interrupt, only: check_interrupt, POLL_MASK
  use mlid_memory, only: no_memory
  use mlid_text, only: itoa
  implicit none
  private
  public :: simulate_outputs, simulate_noise, simulate_flat

contains

  !> simulate_outputs of a model from its flat description (kind, sizes,
  !> constants, options), checked first: the outputs y and states x along
  !> t with inputs u, the noise of theta drawn with seed.
  subroutine simulate_flat(mkind, nx, nu, ny, nw, theta, iconst, rconst, t, u, iopt, ropt, seed, &
                           y, x, status, msg, timing)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, seed
    real(c_double), intent(in) :: theta(:), rconst(:), t(:), u(:, :)
    integer(c_int), intent(in) :: iconst(:), iopt(16)
    real(c_double), intent(in) :: ropt(16)
    real(c_double), intent(out) :: y(:, :), x(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, intent(in), optional :: timing   !< 0 forward (default), 1 backward
    class(model_t), allocatable :: m
    type(options_t) :: opt
    type(param_map_t) :: pm
    integer :: nofree(size(theta))

    y = 0.0_wp
    x = 0.0_wp
    nofree = 0
    ! No measurements yet: check the time base and inputs against themselves.
    call setup(mkind, nx, nu, ny, nw, theta, nofree, no_ties(size(theta)), iconst, rconst, t, u, &
               y, iopt, ropt, 0, m, opt, pm, status, msg)
    if (status /= MLID_OK) return
    call simulate_outputs(m, theta, t, u, opt, seed, y, x, status, msg, timing)
  end subroutine simulate_flat

  !> y(ny, nt) and states xhist(nx, nt) along t with inputs u.
  subroutine simulate_outputs(m, theta, t, u, opt, seed, y, xhist, status, msg, timing)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), t(:), u(:, :)
    type(options_t), intent(in) :: opt
    integer, intent(in) :: seed
    integer, intent(in), optional :: timing   !< 0 forward (default), 1 backward
    real(wp), intent(out) :: y(:, :), xhist(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(layout_t) :: l
    real(wp) :: dhw(m%ny, m%nw), x(m%nx)
    real(wp), allocatable :: w(:, :), noise(:, :)
    logical :: backward, done
    type(rk_work_t) :: wk     !< the integration's work arrays
    integer :: j, nw, ny
    integer, allocatable :: none(:)
    real(wp), allocatable :: ud(:, :)
    integer :: ist

    status = MLID_ERR_INPUT
    l = model_layout(m)
    nw = m%nw
    ny = m%ny
    backward = .false.
    if (present(timing)) then
      if (timing /= 0 .and. timing /= 1) then
        write (msg, '(a,i0)') 'noise timing must be 0 (forward) or 1 (backward), got ', timing
        return
      end if
      backward = timing == 1
    end if
    call simulate_noise(m, theta, size(t), seed, backward, w, noise, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (stabilized(theta, l)) then
      msg = 'a model with a stabilizing gain (stab) runs only against its measured outputs: '// &
            'simulate or predict it with stab = 0'
      return
    end if
    ! inputs that reach the aircraft late (mlid_delay)
    call delay_check(theta(l%oudelay + 1:l%oudelay + m%nu), t, 1, size(t), 1, 'udelay', status, msg)
    if (status /= MLID_OK) return
    allocate (ud(size(u, 1), size(u, 2)), stat=ist)
    if (ist /= 0) then
      call no_memory('the inputs of '//itoa(size(t))//' samples', real(size(u), wp), status, &
        msg)
      return
    end if
    ud(:, :) = u
    call delay_outputs(theta(l%oudelay + 1:l%oudelay + m%nu), t, 1, size(t), ud)
    allocate (none(0))
    done = .false.
    if (all(w == 0.0_wp)) done = as_predicted()
    if (.not. done) call integrate()
    if (status /= MLID_OK) return
    ! sensors that report late (mlid_delay), then their own noise
    call delay_check(theta(l%odelay + 1:l%odelay + ny), t, 1, size(t), 1, 'delay', status, msg)
    if (status /= MLID_OK) return
    call delay_outputs(theta(l%odelay + 1:l%odelay + ny), t, 1, size(t), y)
    y = y + noise
    status = MLID_OK
    msg = ''

  contains

    !> Without process noise, a model the output-error predictor takes to
    !> mlid_lti_predict (a linear one) is simulated there too: a noise-free
    !> record is then the predictor's at these parameters to the bit.
    !> False (and nothing done) for the others, or when a state is not
    !> finite (integrate then says where).
    logical function as_predicted()
      type(param_map_t) :: pm
      real(wp) :: s0(m%nx, 0)
      integer :: pstat
      character(len=len(msg)) :: pmsg
      as_predicted = .false.
      call param_map_create(l, [(0, j=1, l%nth)], no_ties(l%nth), pm, pstat, pmsg)
      if (pstat /= MLID_OK) return
      if (.not. lti_exact(m, theta, pm, t, 1, size(t))) return
      call lti_segment(m, theta, pm, t, ud, opt, 1, 1, size(t), s0, y, pstat, xhist=xhist)
      as_predicted = pstat == MLID_OK
    end function as_predicted

    !> The states and outputs by RK4, sample by sample, with the process noise.
    subroutine integrate()
      x = theta(l%ox0 + 1:l%ox0 + m%nx)
      do j = 1, size(t)
        if (iand(j, POLL_MASK) == 0) then
          call check_interrupt(status, msg)
          if (status /= MLID_OK) return
        end if
        xhist(:, j) = x
        call m%h(t(j), x, ud(:, j), theta(1:l%np), y(:, j))
        y(:, j) = y(:, j) + theta(l%obias + 1:l%obias + ny)
        if (nw > 0) then
          call m%dhdw(t(j), x, ud(:, j), theta(1:l%np), dhw)
          if (backward) then          ! the noise of the interval before the sample
            y(:, j) = y(:, j) + matmul(dhw, w(:, j - 1))
          else
            y(:, j) = y(:, j) + matmul(dhw, w(:, j))
          end if
        end if
        if (j == size(t)) exit
        call rk4_interval(m, theta(1:l%np), t(j), t(j + 1), ud(:, j), ud(:, j + 1), w(:, j), &
                          opt%hold, opt%substeps, x, none, none, [real(wp) ::], wk)
        if (.not. all(ieee_is_finite(x))) then
          status = MLID_ERR_DIVERGED
          write (msg, '(a,g0.6)') 'simulation diverged: state non-finite at t = ', t(j + 1)
          return
        end if
      end do
    end subroutine integrate

  end subroutine simulate_outputs

  !> The noise simulate_outputs draws with seed over nt samples: the process
  !> noise w(nw, 0:nt) (w(:, j) drives the interval after sample j; w(:, 0),
  !> drawn first with the backward timing only, the one before the first
  !> sample) and the measurement noise v(ny, nt).  Zero variances
  !> (noise-free channels) are allowed, and a diagonal covariance gives each
  !> channel its own draw.
  subroutine simulate_noise(m, theta, nt, seed, backward, w, v, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    integer, intent(in) :: nt, seed
    logical, intent(in) :: backward
    real(wp), allocatable, intent(out) :: w(:, :), v(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(layout_t) :: l
    type(rng_t) :: rng
    real(wp) :: c(m%nw + m%ny, m%nw + m%ny), lsq(m%nw + m%ny, m%nw + m%ny)
    real(wp) :: z(m%nw + m%ny), wv(m%nw + m%ny)
    logical :: ok
    integer :: i, j, nw, ny

    l = model_layout(m)
    nw = m%nw
    ny = m%ny
    allocate (w(nw, 0:nt), v(ny, nt), stat=i)
    if (i /= 0) then
      call no_memory('the noise of '//itoa(nt)//' samples', real(nw + ny, wp)*(nt + 1), status, &
        msg)
      return
    end if
    status = MLID_ERR_INPUT
    w = 0.0_wp
    v = 0.0_wp
    if (seed < 0) then
      write (msg, '(a,i0)') 'seed must be >= 0, got ', seed
      return
    end if
    ! the factor of the joint covariance [[Q, S], [S', R]]
    c = 0.0_wp
    do i = 1, nw
      c(i, i) = theta(l%oq + i)
    end do
    do i = 1, ny
      c(nw + i, nw + i) = theta(l%or + i)
    end do
    c(1:nw, nw + 1:) = reshape(theta(l%os + 1:l%os + nw*ny), [nw, ny])
    c(nw + 1:, 1:nw) = transpose(c(1:nw, nw + 1:))
    if (.not. all(ieee_is_finite(c))) then
      msg = 'noise covariances are not finite'
      return
    end if
    call psd_factor(c, lsq, ok)
    if (.not. ok) then
      msg = 'noise covariance [[Q, S], [S'', R]] is not positive semi-definite '// &
            '(variances q, r must be >= 0 and |S| small enough)'
      return
    end if
    call rng_seed(rng, seed)
    do j = merge(0, 1, backward), nt
      do i = 1, nw + ny
        z(i) = rng_normal(rng)
      end do
      wv = matmul(lsq, z)
      w(:, j) = wv(1:nw)
      if (j > 0) v(:, j) = wv(nw + 1:)
    end do
    status = MLID_OK
    msg = ''
  end subroutine simulate_noise

end module mlid_simulate
