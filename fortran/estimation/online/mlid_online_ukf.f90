!> The unscented Kalman filter with the state augmented by the free model
!> parameters (Jategaonkar 2015, sec. 7.3; mlid_online_filter's
!> conventions), in two forms:
!>
!>   standard   2N + 1 sigma points of xa (N = nx + nf), the noise additive:
!>              Pxx = sum wc dx dx' + diag(q),  Pyy = sum wc dy dy' + R;
!>   augmented  the sampled vector is [xa; w; v] (N = nx + nf + nw + ny): the
!>              model's noise inputs w (variances qw) held over the
!>              interval in the integration, v added to the outputs;
!>              Pxx = sum wc dx dx' + diag(q), Pyy = sum wc dy dy'.
!>
!> Sigma points xa +- gamma S(:, i), S the symmetric square root of P
!> (negative eigenvalues taken as 0; Jacobi from the last sample's
!> eigenvectors), gamma = sqrt(N + lambda),
!> lambda = alpha^2 (N + kappa) - N; weights wm(0) = lambda/(N + lambda),
!> wc(0) = wm(0) + 1 - alpha^2 + beta, the others 1/(2 (N + lambda)).
!> Update: K = Pxy Pyy^-1, xa+ = mean + K (z - y mean), P+ = Pxx - K Pyy K'.
!> At the first sample the points are not propagated.
module mlid_online_ukf
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_DIVERGED, MLID_ERR_MEMORY
  use mlid_models, only: model_t
  use mlid_linalg, only: sym_sqrt_jacobi, solve
  use mlid_rk, only: rk_work_t
  use mlid_text, only: itoa
  use mlid_online_filter, only: filter_settings_t, filter_check, filter_propagate, &
                                filter_outputs
  implicit none
  private
  public :: ukf_run

  !> The unscented transform's points and weights (columns 0 to 2 N).
  type :: unscented_t
    integer :: n = 0, na = 0          !< xa's size, the sampled vector's
    real(wp) :: gam = 0.0_wp
    real(wp), allocatable :: wm(:), wc(:), xs(:, :), xt(:, :), ys(:, :)
    real(wp), allocatable :: basis(:, :)   !< the last covariance's eigenvectors (na, na)
  end type unscented_t

contains

  !> est(:, k), sig(:, k): xa+ and sqrt(diag P+) after sample k (as ekf_run);
  !> augmented: the augmented-noise form.
  subroutine ukf_run(m, p, ifree, x0, bias, t, u, z, s, augmented, est, sig, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), x0(:), bias(:), t(:), u(:, :), z(:, :)
    integer, intent(in) :: ifree(:)
    type(filter_settings_t), intent(in) :: s
    logical, intent(in) :: augmented
    real(wp), intent(out) :: est(:, :), sig(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(unscented_t) :: ut
    type(rk_work_t) :: wk
    real(wp), allocatable :: pc(:, :)
    real(wp) :: xa(m%nx + size(ifree))
    integer :: k, n, i, j

    est = 0.0_wp
    sig = 0.0_wp
    n = m%nx + size(ifree)
    call ukf_setup(m, n, s, augmented, ut, status, msg)
    if (status == MLID_OK) call filter_check(m, p, ifree, x0, bias, t, u, z, s, ut%na, status, msg)
    if (status /= MLID_OK) return
    allocate (pc(n, n), source=0.0_wp)
    do i = 1, n
      pc(i, i) = s%p0(i)
    end do
    xa = [x0, p(ifree)]
    do k = 1, size(t)
      call sigma_points(s, m%nw, xa, pc, ut, status)
      if (status /= MLID_OK) exit
      ut%xt = ut%xs(1:n, :)
      if (k > 1) then
        do j = 0, 2*ut%na
          call filter_propagate(m, p, ifree, s, t(k - 1), t(k), u(:, k - 1), u(:, k), &
                                noise(j), ut%xt(:, j), wk)
        end do
      end if
      do j = 0, 2*ut%na
        call filter_outputs(m, p, ifree, bias, t(k), u(:, k), ut%xt(:, j), ut%ys(:, j))
        if (augmented) ut%ys(:, j) = ut%ys(:, j) + ut%xs(n + m%nw + 1:, j)
      end do
      call ukf_update(s, augmented, z(:, k), ut, pc, status)
      xa = ut%xt(:, 0)
      if (status /= MLID_OK .or. .not. all(ieee_is_finite(xa))) exit
      est(:, k) = xa
      sig(:, k) = sqrt(max([(pc(i, i), i=1, n)], 0.0_wp))
    end do
    if (status == MLID_OK .and. k > size(t)) return
    status = MLID_ERR_DIVERGED
    msg = 'unscented Kalman filter diverged at sample '//itoa(k)

  contains

    !> The noise inputs held over the interval by sigma point j.
    function noise(j) result(w)
      integer, intent(in) :: j
      real(wp) :: w(m%nw)
      w = 0.0_wp
      if (augmented) w = ut%xs(n + 1:n + m%nw, j)
    end function noise
  end subroutine ukf_run

  !> The sizes, weights and work arrays of the transform; the augmented
  !> form's own checks.
  subroutine ukf_setup(m, n, s, augmented, ut, status, msg)
    class(model_t), intent(in) :: m
    integer, intent(in) :: n
    type(filter_settings_t), intent(in) :: s
    logical, intent(in) :: augmented
    type(unscented_t), intent(out) :: ut
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: lambda
    integer :: ierr, na
    status = MLID_ERR_INPUT
    msg = ''
    na = n
    if (augmented) then
      na = n + m%nw + m%ny
      if (m%nw == 0) then
        msg = 'the augmented-noise UKF needs a model with noise inputs (nw > 0; a linear '// &
              'model''s Gamma)'
      else if (.not. allocated(s%qw)) then
        msg = 'the augmented-noise UKF needs the noise inputs'' variances'
      else if (size(s%qw) /= m%nw) then
        msg = 'the noise inputs'' variances need '//itoa(m%nw)//' values, got '//itoa(size(s%qw))
      end if
      if (msg /= '') return
    end if
    ut%n = n
    ut%na = na
    lambda = s%alpha**2*(na + merge(s%kappa, 3.0_wp - na, s%kappa_given)) - na
    status = MLID_OK
    if (.not. na + lambda > 0.0_wp) return       ! filter_check says why
    ut%gam = sqrt(na + lambda)
    allocate (ut%wm(0:2*na), ut%wc(0:2*na), ut%xs(na, 0:2*na), ut%xt(n, 0:2*na), &
              ut%ys(m%ny, 0:2*na), ut%basis(na, na), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'unscented Kalman filter: out of memory'
      return
    end if
    ut%basis = 0.0_wp
    do ierr = 1, na
      ut%basis(ierr, ierr) = 1.0_wp
    end do
    ut%wm = 1.0_wp/(2.0_wp*(na + lambda))
    ut%wc = ut%wm
    ut%wm(0) = lambda/(na + lambda)
    ut%wc(0) = ut%wm(0) + 1.0_wp - s%alpha**2 + s%beta
  end subroutine ukf_setup

  !> ut%xs: the sigma points of [xa; w; v] around [xm; 0; 0], covariance
  !> diag(P, qw, r) (or xa's alone, P, in the standard form).
  subroutine sigma_points(s, nw, xm, pc, ut, status)
    type(filter_settings_t), intent(in) :: s
    integer, intent(in) :: nw
    real(wp), intent(in) :: xm(:), pc(:, :)
    type(unscented_t), intent(inout) :: ut
    integer, intent(out) :: status
    real(wp) :: pa(ut%na, ut%na), sq(ut%na, ut%na)
    integer :: i, n
    n = ut%n
    pa = 0.0_wp
    pa(1:n, 1:n) = pc
    do i = n + 1, ut%na                        ! the augmented form's noise
      if (i <= n + nw) then
        pa(i, i) = s%qw(i - n)
      else
        pa(i, i) = s%r(i - n - nw)
      end if
    end do
    call sym_sqrt_jacobi(pa, ut%basis, sq, status)   ! from the last sample's basis
    if (status /= 0) return
    ut%xs = 0.0_wp
    ut%xs(1:n, :) = spread(xm, 2, 2*ut%na + 1)
    ut%xs(:, 1:ut%na) = ut%xs(:, 1:ut%na) - ut%gam*sq
    ut%xs(:, ut%na + 1:) = ut%xs(:, ut%na + 1:) + ut%gam*sq
  end subroutine sigma_points

  !> The update from the propagated points ut%xt and their outputs ut%ys;
  !> the estimate left in ut%xt(:, 0).
  subroutine ukf_update(s, augmented, z, ut, pc, status)
    type(filter_settings_t), intent(in) :: s
    logical, intent(in) :: augmented
    real(wp), intent(in) :: z(:)
    type(unscented_t), intent(inout) :: ut
    real(wp), intent(inout) :: pc(:, :)
    integer, intent(out) :: status
    real(wp) :: xm(ut%n), ym(size(z)), dx(ut%n, 0:2*ut%na), dy(size(z), 0:2*ut%na), &
                pyy(size(z), size(z)), pxy(ut%n, size(z)), kt(size(z), ut%n)
    integer :: i
    xm = matmul(ut%xt, ut%wm)
    ym = matmul(ut%ys, ut%wm)
    dx = ut%xt - spread(xm, 2, 2*ut%na + 1)
    dy = ut%ys - spread(ym, 2, 2*ut%na + 1)
    pc = matmul(dx*spread(ut%wc, 1, ut%n), transpose(dx))
    pyy = matmul(dy*spread(ut%wc, 1, size(z)), transpose(dy))
    pxy = matmul(dx*spread(ut%wc, 1, ut%n), transpose(dy))
    do i = 1, ut%n
      pc(i, i) = pc(i, i) + s%q(i)
    end do
    if (.not. augmented) then
      do i = 1, size(z)
        pyy(i, i) = pyy(i, i) + s%r(i)
      end do
    end if
    call solve(pyy, transpose(pxy), kt, status)   ! K' = Pyy^-1 Pxy'
    if (status /= 0) return
    ut%xt(:, 0) = xm + matmul(transpose(kt), z - ym)
    pc = pc - matmul(transpose(kt), matmul(pyy, kt))
    pc = 0.5_wp*(pc + transpose(pc))
  end subroutine ukf_update

end module mlid_online_ukf
