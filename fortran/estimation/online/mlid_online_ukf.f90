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
!> (negative eigenvalues taken as 0), gamma = sqrt(N + lambda),
!> lambda = alpha^2 (N + kappa) - N; weights wm(0) = lambda/(N + lambda),
!> wc(0) = wm(0) + 1 - alpha^2 + beta, the others 1/(2 (N + lambda)).
!> The symmetric root, not a Cholesky factor, because the textbook's
!> ukf_mod takes sqrtm(P): another root spreads other points, which moves
!> the result of a model that is not linear (the short period is bilinear
!> in states and parameters) away from the reference's.  It comes from
!> Jacobi rotations started at the last sample's eigenvectors
!> (mlid_linalg's sym_sqrt_jacobi), a sweep or none a sample, where a fresh
!> LAPACK decomposition costs several times more at N ~ 10.  In the
!> augmented form P is block diagonal, diag(P, qw, r), so its root is
!> sqrt(P)'s block and the noise's square roots: the points that move v
!> alone share the centre's propagation and outputs (v only adds to y).
!> Update: K = Pxy Pyy^-1, xa+ = mean + K (z - y mean), P+ = Pxx - K Pyy K'.
!> At the first sample the points are not propagated.
!>
!> R adapted (s%r_fade > 0, mlid_online_filter's filter_adapt_r, as the
!> EKF's): from the residual after the update e = z - y(xa+), E{e e'} =
!> R - C P+ C', with C P+ C' from the transform's own moments, C Pxx C' =
!> Pyy - R and C K = (Pyy - R) Pyy^-1, so C P+ C' = R - R Pyy^-1 R.  Not
!> the innovation form (R = nu nu' - (Pyy - R), nu = z - y mean): that
!> subtracts the points' spread from one squared innovation, negative
!> whenever P is large against R (the start); the residual form adds two
!> nonnegative terms and equals the EKF's for a linear model.  In the
!> augmented form the adapted R is the sampled v's variance at the next
!> sample (v is additive, so the same relation holds).
module mlid_online_ukf
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_DIVERGED, MLID_ERR_MEMORY
  use mlid_models, only: model_t
  use mlid_linalg, only: sym_sqrt_jacobi, chol_inverse, dot2
  use mlid_rk, only: rk_work_t
  use mlid_text, only: itoa
  use mlid_online_filter, only: filter_settings_t, filter_check, filter_propagate, &
                                filter_outputs, filter_adapt_r
  implicit none
  private
  public :: ukf_run

  !> The unscented transform's points and weights (columns 0 to 2 na) and
  !> the update's work arrays, sized once (ukf_setup): a sample allocates
  !> nothing.
  type :: unscented_t
    integer :: n = 0, na = 0, nw = 0, ny = 0   !< xa's size, the sampled vector's, w's, y's
    real(wp) :: gam = 0.0_wp
    real(wp), allocatable :: wm(:), wc(:)
    real(wp), allocatable :: xs(:, :)          !< (na, 0:2 na) the points of [xa; w; v]
    real(wp), allocatable :: xt(:, :)          !< (n, 0:2 na) propagated; then less their mean
    real(wp), allocatable :: ys(:, :)          !< (ny, 0:2 na) their outputs; then less the mean
    real(wp), allocatable :: sq(:, :), basis(:, :)   !< (n, n) sqrt(P), P's last eigenvectors
    real(wp), allocatable :: sn(:)             !< (na - n) the noise's standard deviations
    real(wp), allocatable :: xm(:), ym(:), pyy(:, :), pyi(:, :), pxy(:, :), kg(:, :), &
                             w0(:), r(:), cpc(:)
    !> (0:2 na, n or ny) the points' deviations from the mean, a point a
    !> row, and times wc: the covariances' sums as contiguous dot products
    real(wp), allocatable :: dx(:, :), wdx(:, :), dy(:, :), wdy(:, :)
  end type unscented_t

contains

  !> est(:, k), sig(:, k): xa+ and sqrt(diag P+) after sample k (as ekf_run);
  !> rhist(:, k): R's diagonal used at sample k+1 (s%r throughout unless
  !> adaptive); augmented: the augmented-noise form.
  subroutine ukf_run(m, p, ifree, x0, bias, t, u, z, s, augmented, est, sig, rhist, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), x0(:), bias(:), t(:), u(:, :), z(:, :)
    integer, intent(in) :: ifree(:)
    type(filter_settings_t), intent(in) :: s
    logical, intent(in) :: augmented
    real(wp), intent(out) :: est(:, :), sig(:, :), rhist(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(unscented_t) :: ut
    type(rk_work_t) :: wk
    real(wp), allocatable :: pc(:, :), xa(:)
    integer :: k, n, i

    est = 0.0_wp
    sig = 0.0_wp
    rhist = 0.0_wp
    n = m%nx + size(ifree)
    call ukf_setup(m, n, s, augmented, ut, status, msg)
    if (status == MLID_OK) call filter_check(m, p, ifree, x0, bias, t, u, z, s, ut%na, status, msg)
    if (status /= MLID_OK) return
    allocate (pc(n, n), xa(n), stat=i)
    if (i /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'unscented Kalman filter: out of memory'
      return
    end if
    pc = 0.0_wp
    do i = 1, n
      pc(i, i) = s%p0(i)
    end do
    xa = [x0, p(ifree)]
    ut%r = s%r
    do k = 1, size(t)
      call sigma_points(s, xa, pc, ut, status)
      if (status /= MLID_OK) exit
      call sigma_outputs(m, p, ifree, bias, s, t, u, k, ut, wk)
      call ukf_update(s%q, augmented, z(:, k), ut, xa, pc, status)
      if (status /= MLID_OK .or. .not. all(ieee_is_finite(xa))) exit
      if (s%r_fade > 0.0_wp) then
        do i = 1, ut%ny                         ! diag(C P+ C') = diag(R - R Pyy^-1 R)
          ut%cpc(i) = max(ut%r(i)*(1.0_wp - ut%r(i)*ut%pyi(i, i)), 0.0_wp)
        end do
        call filter_adapt_r(m, p, ifree, bias, t(k), u(:, k), z(:, k), xa, ut%cpc, k, &
                            s%r_fade, ut%r)
      end if
      rhist(:, k) = ut%r
      est(:, k) = xa
      do i = 1, n
        sig(i, k) = sqrt(max(pc(i, i), 0.0_wp))
      end do
    end do
    if (status == MLID_OK .and. k > size(t)) return
    status = MLID_ERR_DIVERGED
    msg = 'unscented Kalman filter diverged at sample '//itoa(k)
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
    integer :: ierr, na, ny
    status = MLID_ERR_INPUT
    msg = ''
    na = n
    ny = m%ny
    if (augmented) then
      na = n + m%nw + ny
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
    ut%nw = merge(m%nw, 0, augmented)
    ut%ny = ny
    lambda = s%alpha**2*(na + merge(s%kappa, 3.0_wp - na, s%kappa_given)) - na
    status = MLID_OK
    if (.not. na + lambda > 0.0_wp) return       ! filter_check says why
    ut%gam = sqrt(na + lambda)
    allocate (ut%wm(0:2*na), ut%wc(0:2*na), ut%xs(na, 0:2*na), ut%xt(n, 0:2*na), &
              ut%ys(ny, 0:2*na), ut%sq(n, n), ut%basis(n, n), ut%sn(na - n), ut%xm(n), &
              ut%ym(ny), ut%pyy(ny, ny), ut%pyi(ny, ny), ut%pxy(n, ny), ut%kg(n, ny), &
              ut%w0(m%nw), ut%r(ny), ut%cpc(ny), ut%dx(0:2*na, n), ut%wdx(0:2*na, n), &
              ut%dy(0:2*na, ny), ut%wdy(0:2*na, ny), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'unscented Kalman filter: out of memory'
      return
    end if
    ut%basis = 0.0_wp
    do ierr = 1, n
      ut%basis(ierr, ierr) = 1.0_wp
    end do
    ut%w0 = 0.0_wp
    ut%xs = 0.0_wp
    ut%wm = 1.0_wp/(2.0_wp*(na + lambda))
    ut%wc = ut%wm
    ut%wm(0) = lambda/(na + lambda)
    ut%wc(0) = ut%wm(0) + 1.0_wp - s%alpha**2 + s%beta
  end subroutine ukf_setup

  !> ut%xs: the sigma points of [xa; w; v] around [xm; 0; 0], covariance
  !> diag(P, qw, R) (or xa's alone, P, in the standard form): columns 1 to
  !> na less gamma times the root's columns, na + 1 to 2 na plus.  The
  !> noise rows of the state columns and the state rows of the noise
  !> columns stay as ukf_setup left them (zero) but for xm.
  subroutine sigma_points(s, xm, pc, ut, status)
    type(filter_settings_t), intent(in) :: s
    real(wp), intent(in) :: xm(:), pc(:, :)
    type(unscented_t), intent(inout) :: ut
    integer, intent(out) :: status
    integer :: i, n, na
    n = ut%n
    na = ut%na
    call sym_sqrt_jacobi(pc, ut%basis, ut%sq, status)   ! from the last sample's basis
    if (status /= 0) return
    do i = 1, na - n                           ! the augmented form's noise
      if (i <= ut%nw) then
        ut%sn(i) = sqrt(s%qw(i))
      else
        ut%sn(i) = sqrt(ut%r(i - ut%nw))
      end if
    end do
    ut%xs(1:n, 0) = xm
    do i = 1, n
      ut%xs(1:n, i) = xm - ut%gam*ut%sq(:, i)
      ut%xs(1:n, na + i) = xm + ut%gam*ut%sq(:, i)
    end do
    do i = n + 1, na
      ut%xs(1:n, i) = xm
      ut%xs(1:n, na + i) = xm
      ut%xs(i, i) = -ut%gam*ut%sn(i - n)
      ut%xs(i, na + i) = ut%gam*ut%sn(i - n)
    end do
  end subroutine sigma_points

  !> ut%xt, ut%ys: the points carried from sample k - 1 to k (not at the
  !> first sample) and their outputs (plus v in the augmented form).  The
  !> points that move v alone (columns past n + nw) take the centre's.
  subroutine sigma_outputs(m, p, ifree, bias, s, t, u, k, ut, wk)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), bias(:), t(:), u(:, :)
    integer, intent(in) :: ifree(:), k
    type(filter_settings_t), intent(in) :: s
    type(unscented_t), intent(inout) :: ut
    type(rk_work_t), intent(inout) :: wk
    integer :: j, n, nw, na
    n = ut%n
    nw = ut%nw
    na = ut%na
    do j = 0, 2*na
      if (j > 0 .and. mod(j - 1, na) + 1 > n + nw) then   ! v alone: the centre's, plus v
        ut%xt(:, j) = ut%xt(:, 0)
        ut%ys(:, j) = ut%ys(:, 0) + ut%xs(n + nw + 1:, j)
        cycle
      end if
      ut%xt(:, j) = ut%xs(1:n, j)
      if (k > 1) then
        if (nw > 0) then
          call filter_propagate(m, p, ifree, s, t(k - 1), t(k), u(:, k - 1), u(:, k), &
                                ut%xs(n + 1:n + nw, j), ut%xt(:, j), wk)
        else
          call filter_propagate(m, p, ifree, s, t(k - 1), t(k), u(:, k - 1), u(:, k), &
                                ut%w0, ut%xt(:, j), wk)
        end if
      end if
      call filter_outputs(m, p, ifree, bias, t(k), u(:, k), ut%xt(:, j), ut%ys(:, j))
    end do
  end subroutine sigma_outputs

  !> The update from the propagated points ut%xt and their outputs ut%ys:
  !> xa+ and P+; ut%pyi = Pyy^-1 (status /= 0: Pyy is not positive
  !> definite).
  subroutine ukf_update(q, augmented, z, ut, xa, pc, status)
    real(wp), intent(in) :: q(:), z(:)
    logical, intent(in) :: augmented
    type(unscented_t), intent(inout) :: ut
    real(wp), intent(out) :: xa(:)
    real(wp), intent(inout) :: pc(:, :)
    integer, intent(out) :: status
    real(wp) :: logdet
    integer :: i, j, c, n, ny
    n = ut%n
    ny = ut%ny
    ut%xm = ut%wm(0)*ut%xt(:, 0)
    ut%ym = ut%wm(0)*ut%ys(:, 0)
    do j = 1, 2*ut%na
      ut%xm = ut%xm + ut%wm(j)*ut%xt(:, j)
      ut%ym = ut%ym + ut%wm(j)*ut%ys(:, j)
    end do
    do j = 0, 2*ut%na                          ! the deviations, a point a row
      ut%dx(j, :) = ut%xt(:, j) - ut%xm
      ut%dy(j, :) = ut%ys(:, j) - ut%ym
    end do
    do c = 1, ny
      ut%wdy(:, c) = ut%wc*ut%dy(:, c)
    end do
    do c = 1, n                                ! sums over the points: dot products
      ut%wdx(:, c) = ut%wc*ut%dx(:, c)
      do i = 1, c
        pc(i, c) = dot2(2*ut%na + 1, ut%wdx(:, i), ut%dx(:, c))
      end do
    end do
    do c = 1, ny
      do i = 1, n
        ut%pxy(i, c) = dot2(2*ut%na + 1, ut%wdx(:, i), ut%dy(:, c))
      end do
      do i = 1, c
        ut%pyy(i, c) = dot2(2*ut%na + 1, ut%wdy(:, i), ut%dy(:, c))
      end do
    end do
    do c = 1, n
      pc(c, c) = pc(c, c) + q(c)
    end do
    if (.not. augmented) then
      do c = 1, ny
        ut%pyy(c, c) = ut%pyy(c, c) + ut%r(c)
      end do
    end if
    do c = 1, ny
      ut%pyy(c, 1:c - 1) = ut%pyy(1:c - 1, c)
    end do
    xa = ut%xm                                 ! the prediction, if the update fails
    call chol_inverse(ut%pyy, ut%pyi, logdet, status)
    if (status /= 0) return
    do c = 1, ny                               ! K = Pxy Pyy^-1
      ut%kg(:, c) = ut%pxy(:, 1)*ut%pyi(1, c)
      do i = 2, ny
        ut%kg(:, c) = ut%kg(:, c) + ut%pxy(:, i)*ut%pyi(i, c)
      end do
    end do
    do c = 1, ny
      xa = xa + ut%kg(:, c)*(z(c) - ut%ym(c))
    end do
    do c = 1, ny                               ! P+ = Pxx - K Pyy K' = Pxx - K Pxy'
      do j = 1, n
        pc(1:j, j) = pc(1:j, j) - ut%kg(1:j, c)*ut%pxy(j, c)
      end do
    end do
    do j = 1, n
      pc(j, 1:j - 1) = pc(1:j - 1, j)
    end do
  end subroutine ukf_update

end module mlid_online_ukf
