!> What the augmented-state Kalman filters for parameter estimation share
!> (mlid_online_ekf, mlid_online_ukf; Jategaonkar 2015, sec. 7.2-7.3):
!> the state xa = [x(nx); p(ifree)] carries the free model parameters as
!> states with zero dynamics (a random walk with variance q(nx+j) per
!> sample when given, to track a change).  Between samples the states move
!> by the model's own integration (mlid_rk: RK4, the input linear between
!> the samples unless held), the parameters do not; the outputs are the
!> model's h plus the fixed output biases.  The first sample is an update
!> without a propagation: xa0 and P0 are the predicted values at t(1).
module mlid_online_filter
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t
  use mlid_rk, only: rk4_interval, rk_work_t
  use mlid_text, only: itoa
  implicit none
  private
  public :: filter_settings_t, filter_check, filter_propagate, filter_outputs, filter_params
  public :: FORGET_RANGE

  character(len=*), parameter :: FORGET_RANGE = 'the forgetting factor must be in (0, 1], 1 for none'
  public :: filter_adapt_r

  !> The filters' settings.  p0, q: the start covariance and the process
  !> noise (variances, discrete: added to P at each propagation) of xa
  !> (nx + nf), the states first; r: the measurement-noise variances (ny);
  !> qw: the variances of the model's noise inputs w (nw), held over an
  !> interval (the augmented-noise UKF only).  alpha, beta, kappa: the
  !> unscented transform's spread, prior and scaling (kappa_given false:
  !> kappa = 3 - N, N the dimension sampled).  hold, nsub: the integration's
  !> input hold and RK4 steps per interval (options_t's).
  type :: filter_settings_t
    real(wp), allocatable :: p0(:), q(:), r(:), qw(:)
    real(wp) :: alpha = 0.5_wp, beta = 2.0_wp, kappa = 0.0_wp
    logical :: kappa_given = .false.
    logical :: hold = .false.
    integer :: nsub = 1
    real(wp) :: delta = 0.0_wp   !< > 0: the EKF's Jacobians by central differences (the textbook's)
    real(wp) :: r_fade = 0.0_wp  !< in (0, 1): R adapted, this fading memory (0: R given)
    !> in (0, 1]: the EKF run as extended forgetting-factor least squares
    !> (mlid_online_ekf), this forgetting factor (0: the Kalman filter)
    real(wp) :: forget = 0.0_wp
  end type filter_settings_t

contains

  !> The model parameters with the free ones taken from xa.
  pure subroutine filter_params(m, p, ifree, xa, pp)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), xa(:)
    integer, intent(in) :: ifree(:)
    real(wp), intent(out) :: pp(:)
    pp = p
    pp(ifree) = xa(m%nx + 1:)
  end subroutine filter_params

  !> xa's states from t0 to t1 (inputs u0, u1; noise inputs w held), the
  !> parameters in xa held.
  subroutine filter_propagate(m, p, ifree, s, t0, t1, u0, u1, w, xa, wk)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), t0, t1, u0(:), u1(:), w(:)
    integer, intent(in) :: ifree(:)
    type(filter_settings_t), intent(in) :: s
    real(wp), intent(inout) :: xa(:)
    type(rk_work_t), intent(inout) :: wk
    real(wp) :: pp(size(p)), none(0)
    integer :: inone(0)
    call filter_params(m, p, ifree, xa, pp)
    call rk4_interval(m, pp, t0, t1, u0, u1, w, s%hold, s%nsub, xa(1:m%nx), inone, inone, &
                      none, wk)
  end subroutine filter_propagate

  !> y = h(t, x, u) + bias at xa (the model's parameters from it), and
  !> when asked c = d y / d xa (ny, nx + nf), exact.
  subroutine filter_outputs(m, p, ifree, bias, t, u, xa, y, c)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), bias(:), t, u(:), xa(:)
    integer, intent(in) :: ifree(:)
    real(wp), intent(out) :: y(:)
    real(wp), intent(out), optional :: c(:, :)
    real(wp) :: pp(size(p)), uw(m%nu + m%nw)
    integer :: nx
    nx = m%nx
    call filter_params(m, p, ifree, xa, pp)
    uw = 0.0_wp
    uw(1:m%nu) = u
    if (present(c)) then
      call m%eval(t, xa(1:nx), uw, pp, ifree, y=y, c=c(:, 1:nx), d=c(:, nx + 1:))
    else
      call m%eval(t, xa(1:nx), uw, pp, ifree, y=y)
    end if
    y = y + bias
  end subroutine filter_outputs

  !> Adaptive R (Sage and Husa's fading memory, diagonal) after the update
  !> at sample k: from the residual e = z - y(xa+), E{e e'} = R - C P+ C', so
  !>   R <- (1 - dk) R + dk (e^2 + cpc),  dk = (1 - b)/(1 - b^k),
  !> cpc = diag(C P+ C') (each filter's own: the EKF's Jacobian, the UKF's
  !> transform), b the fading factor (about 1/(1 - b) samples remembered).
  subroutine filter_adapt_r(m, p, ifree, bias, t, u, z, xa, cpc, k, b, r)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), bias(:), t, u(:), z(:), xa(:), cpc(:), b
    integer, intent(in) :: ifree(:), k
    real(wp), intent(inout) :: r(:)
    real(wp) :: y(m%ny), dk
    integer :: i
    call filter_outputs(m, p, ifree, bias, t, u, xa, y)
    dk = (1.0_wp - b)/(1.0_wp - b**k)
    do i = 1, m%ny
      r(i) = max((1.0_wp - dk)*r(i) + dk*((z(i) - y(i))**2 + cpc(i)), tiny(1.0_wp))
    end do
  end subroutine filter_adapt_r

  !> The settings and the record checked against the model: one line on
  !> the first problem.  ukf_dim: the dimension the unscented transform
  !> samples (0 for the EKF).
  subroutine filter_check(m, p, ifree, x0, bias, t, u, z, s, ukf_dim, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), x0(:), bias(:), t(:), u(:, :), z(:, :)
    integer, intent(in) :: ifree(:), ukf_dim
    type(filter_settings_t), intent(in) :: s
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: n
    status = MLID_ERR_INPUT
    n = m%nx + size(ifree)
    call check_sizes(m, p, ifree, x0, bias, t, u, z, s, msg)
    if (msg /= '') return
    if (.not. (all(s%p0 > 0.0_wp) .and. all(ieee_is_finite(s%p0)))) then
      msg = 'p0 (the start variances of states and parameters) must be > 0 and finite'
    else if (.not. (all(s%q >= 0.0_wp) .and. all(ieee_is_finite(s%q)))) then
      msg = 'q (the process-noise variances of states and parameters) must be >= 0 and finite'
    else if (.not. (all(s%r > 0.0_wp) .and. all(ieee_is_finite(s%r)))) then
      msg = 'r (the measurement-noise variances) must be > 0 and finite'
    else if (.not. (all(ieee_is_finite(x0)) .and. all(ieee_is_finite(p)) .and. &
                    all(ieee_is_finite(u)) .and. all(ieee_is_finite(z)) .and. &
                    all(ieee_is_finite(bias)))) then
      msg = 'online filter: start values, inputs and measurements must be finite'
    else if (any(t(2:) <= t(:size(t) - 1))) then
      msg = 'online filter: the times must increase'
    else if (.not. (s%delta >= 0.0_wp .and. ieee_is_finite(s%delta))) then
      msg = 'the difference step delta must be >= 0 (0: exact Jacobians) and finite'
    else if (.not. (s%r_fade >= 0.0_wp .and. s%r_fade < 1.0_wp)) then
      msg = 'the fading factor of the adaptive R must be in [0, 1) (0: R given)'
    else if (.not. (s%forget >= 0.0_wp .and. s%forget <= 1.0_wp)) then
      msg = FORGET_RANGE
    else if (s%forget > 0.0_wp .and. (ukf_dim > 0 .or. s%r_fade > 0.0_wp)) then
      msg = 'forgetting is the extended Kalman filter''s, with R given'
    else if (ukf_dim > 0) then
      call check_unscented(s, ukf_dim, msg)
    end if
    if (msg == '') status = MLID_OK
  end subroutine filter_check

  subroutine check_sizes(m, p, ifree, x0, bias, t, u, z, s, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), x0(:), bias(:), t(:), u(:, :), z(:, :)
    integer, intent(in) :: ifree(:)
    type(filter_settings_t), intent(in) :: s
    character(len=*), intent(out) :: msg
    integer :: n, j
    n = m%nx + size(ifree)
    msg = ''
    if (size(t) < 1) then
      msg = 'online filter: the record has no samples'
    else if (size(u, 1) /= m%nu .or. size(z, 1) /= m%ny .or. size(u, 2) /= size(t) .or. &
             size(z, 2) /= size(t) .or. size(x0) /= m%nx .or. size(bias) /= m%ny .or. &
             size(p) /= m%np) then
      msg = 'online filter: the record, start states or biases do not fit the model'
    else if (any(ifree < 1 .or. ifree > m%np)) then
      msg = 'online filter: a free parameter is not a model parameter (1 to '//itoa(m%np)//')'
    else if (size(s%p0) /= n .or. size(s%q) /= n) then
      msg = 'p0 and q need '//itoa(n)//' values (the states, then the free parameters), got '// &
            itoa(size(s%p0))//' and '//itoa(size(s%q))
    else if (size(s%r) /= m%ny) then
      msg = 'r needs '//itoa(m%ny)//' values (one per output), got '//itoa(size(s%r))
    end if
    do j = 2, size(ifree)
      if (msg == '' .and. any(ifree(:j - 1) == ifree(j))) &
        msg = 'online filter: free parameter '//itoa(ifree(j))//' listed twice'
    end do
  end subroutine check_sizes

  subroutine check_unscented(s, na, msg)
    type(filter_settings_t), intent(in) :: s
    integer, intent(in) :: na
    character(len=*), intent(out) :: msg
    real(wp) :: kappa
    msg = ''
    kappa = merge(s%kappa, 3.0_wp - na, s%kappa_given)
    if (.not. (s%alpha > 0.0_wp .and. s%alpha <= 1.0_wp)) then
      msg = 'the unscented transform''s alpha must be in (0, 1]'
    else if (.not. (ieee_is_finite(s%beta) .and. ieee_is_finite(kappa))) then
      msg = 'the unscented transform''s beta and kappa must be finite'
    else if (.not. s%alpha**2*(na + kappa) > 0.0_wp) then
      msg = 'the unscented transform needs alpha^2 (N + kappa) > 0 (N = '//itoa(na)//')'
    else if (allocated(s%qw)) then
      if (.not. (all(s%qw >= 0.0_wp) .and. all(ieee_is_finite(s%qw)))) &
        msg = 'the noise inputs'' variances q must be >= 0 and finite'
    end if
  end subroutine check_unscented

end module mlid_online_filter
