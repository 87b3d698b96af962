!> The extended Kalman filter with the state augmented by the free model
!> parameters (Jategaonkar 2015, sec. 7.2; mlid_online_filter's
!> conventions), with the model's exact Jacobians:
!>
!>   prediction  xa- by the model's integration over [t(k-1), t(k)],
!>               Phi = exp(A dt), A = [df/dx df/dp; 0 0] at xa+(k-1), u(k-1),
!>               P- = Phi P+ Phi' + diag(q)
!>   update      C = [dh/dx dh/dp] at xa-, K = P- C' (C P- C' + R)^-1,
!>               xa+ = xa- + K (z - y),
!>               P+ = (I - K C) P- (I - K C)' + K R K'   (Joseph form)
!>
!> Phi = [E G; 0 I] with E = exp(F dt), G = int_0^dt exp(F s) ds B (F =
!> df/dx, B = df/dp), both from one exponential of [F I; 0 0] dt (2 nx
!> square), and P- and the Joseph form by blocks: O(nx n^2) and O(ny n^2)
!> a sample, not O(n^3).  The textbook's code takes A and C by central
!> differences and Phi by a 10-term Taylor series; for a model bilinear in
!> states and parameters (the short period) the differences are exact to
!> rounding.  R is given, or adapted from the residuals after each update
!> (mlid_online_filter's filter_adapt_r).
!>
!> With a forgetting factor lambda (s%forget > 0) the same recursion is the
!> textbook's extended forgetting-factor least squares (EFRLS, sec. 7.4):
!> the innovation weighted by lambda R, P+ divided by lambda after each
!> update (old samples' weight decays as lambda^k), and no update at the
!> first sample (x0, p0 are the estimate there).  The textbook takes R = I
!> (unit weights, so its "sigma" is not a standard deviation) and C at the
!> previous estimate; here R is the one given (the noise variances make P a
!> covariance, inflated by the forgetting) and C at the prediction, exact.
module mlid_online_ekf
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_DIVERGED, MLID_ERR_MEMORY
  use mlid_models, only: model_t
  use mlid_linalg, only: expm_into, expm_work_size, expm_work_t, chol_inverse
  use mlid_rk, only: rk_work_t
  use mlid_text, only: itoa
  use mlid_online_filter, only: filter_settings_t, filter_check, filter_propagate, &
                                filter_outputs, filter_params, filter_adapt_r
  implicit none
  private
  public :: ekf_run

contains

  !> est(:, k), sig(:, k): xa+ and sqrt(diag P+) after sample k of the
  !> record (t, u, z), from the states x0 and the model parameters p (its
  !> free ones ifree the start of their estimates), output biases bias;
  !> rhist(:, k): R's diagonal used at sample k+1 (s%r throughout unless
  !> adaptive, s%r_fade > 0: filter_adapt_r).
  subroutine ekf_run(m, p, ifree, x0, bias, t, u, z, s, est, sig, rhist, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), x0(:), bias(:), t(:), u(:, :), z(:, :)
    integer, intent(in) :: ifree(:)
    type(filter_settings_t), intent(in) :: s
    real(wp), intent(out) :: est(:, :), sig(:, :), rhist(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: pc(:, :), phi(:, :), w(:)   ! phi: [E G], nx x n
    real(wp) :: xa(m%nx + size(ifree)), r(m%ny), rw(m%ny), c(m%ny, m%nx + size(ifree))
    type(rk_work_t) :: wk
    type(expm_work_t) :: ew
    real(wp) :: lam          ! the forgetting factor (1: none); rw = lam r, the update's weights
    integer :: k, n, i, ierr

    est = 0.0_wp
    sig = 0.0_wp
    rhist = 0.0_wp
    call filter_check(m, p, ifree, x0, bias, t, u, z, s, 0, status, msg)
    if (status /= MLID_OK) return
    n = size(xa)
    r = s%r
    lam = merge(s%forget, 1.0_wp, s%forget > 0.0_wp)
    rw = lam*r
    allocate (pc(n, n), phi(m%nx, n), w(m%nw), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'extended Kalman filter: out of memory'
      return
    end if
    call expm_work_size(ew, 2*m%nx)
    w = 0.0_wp
    xa = [x0, p(ifree)]
    pc = 0.0_wp
    do i = 1, n
      pc(i, i) = s%p0(i)
    end do
    do k = 1, size(t)
      if (k > 1) then
        call transition(m, p, ifree, s%delta, t(k) - t(k - 1), t(k - 1), u(:, k - 1), xa, &
                        phi, ew, status)
        if (status /= MLID_OK) exit
        call filter_propagate(m, p, ifree, s, t(k - 1), t(k), u(:, k - 1), u(:, k), w, xa, wk)
        call propagate_covariance(m%nx, phi, pc)
        do i = 1, n
          pc(i, i) = pc(i, i) + s%q(i)
        end do
      end if
      if (k > 1 .or. s%forget == 0.0_wp) then
        call ekf_update(m, p, ifree, bias, rw, s%delta, t(k), u(:, k), z(:, k), xa, pc, c, &
                        status)
        if (status /= MLID_OK .or. .not. all(ieee_is_finite(xa))) exit
        if (lam < 1.0_wp) pc = pc/lam
      end if
      if (s%r_fade > 0.0_wp) then        ! (no forgetting then: rw is r)
        call filter_adapt_r(m, p, ifree, bias, t(k), u(:, k), z(:, k), xa, cpc_diag(c, pc), k, &
                            s%r_fade, r)
        rw = r
      end if
      rhist(:, k) = r
      est(:, k) = xa
      do i = 1, n
        sig(i, k) = sqrt(max(pc(i, i), 0.0_wp))
      end do
    end do
    if (status == MLID_OK .and. k > size(t)) then
      msg = ''
      return
    end if
    status = MLID_ERR_DIVERGED
    msg = 'extended Kalman filter diverged at sample '//itoa(k)
  end subroutine ekf_run

  !> phi = [E G], the states' rows of exp(A dt) for the augmented A =
  !> [F B; 0 0] at xa, u (the model's exact Jacobians): the exponential of
  !> [F I; 0 0] dt is [E H; 0 I], H = int_0^dt exp(F s) ds, and G = H B.
  subroutine transition(m, p, ifree, delta, dt, t0, u0, xa, phi, ew, status)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), delta, dt, t0, u0(:), xa(:)
    integer, intent(in) :: ifree(:)
    real(wp), intent(out) :: phi(:, :)
    type(expm_work_t), intent(inout) :: ew
    integer, intent(out) :: status
    real(wp) :: ab(m%nx, size(xa)), pp(size(p)), uw(m%nu + m%nw), a2(2*m%nx, 2*m%nx), &
                e2(2*m%nx, 2*m%nx)
    integer :: nx, i
    nx = m%nx
    call filter_params(m, p, ifree, xa, pp)
    uw = 0.0_wp
    uw(1:m%nu) = u0
    if (delta > 0.0_wp) then
      call central_differences(m, p, ifree, t0, uw, xa, delta, .true., ab)
    else
      call m%eval(t0, xa(1:nx), uw, pp, ifree, a=ab(:, 1:nx), b=ab(:, nx + 1:))
    end if
    a2 = 0.0_wp
    a2(1:nx, 1:nx) = ab(:, 1:nx)*dt
    do i = 1, nx
      a2(i, nx + i) = dt
    end do
    call expm_into(a2, e2, status, ew)
    phi(:, 1:nx) = e2(1:nx, 1:nx)
    phi(:, nx + 1:) = matmul(e2(1:nx, nx + 1:), ab(:, nx + 1:))
  end subroutine transition

  !> P <- Phi P Phi' for Phi = [phi; 0 I] (phi = [E G], the states' rows):
  !> the parameters' block stays, the states' rows are phi P Phi'.
  pure subroutine propagate_covariance(nx, phi, pc)
    integer, intent(in) :: nx
    real(wp), intent(in) :: phi(:, :)
    real(wp), intent(inout) :: pc(:, :)
    real(wp) :: top(nx, size(pc, 1))
    top = matmul(phi, pc)                                   ! rows 1:nx of Phi P
    pc(1:nx, 1:nx) = matmul(top(:, 1:nx), transpose(phi(:, 1:nx))) + &
                     matmul(top(:, nx + 1:), transpose(phi(:, nx + 1:)))
    pc(1:nx, nx + 1:) = top(:, nx + 1:)
    pc(nx + 1:, 1:nx) = transpose(top(:, nx + 1:))
    pc(1:nx, 1:nx) = 0.5_wp*(pc(1:nx, 1:nx) + transpose(pc(1:nx, 1:nx)))
  end subroutine propagate_covariance

  !> The measurement update at one sample, Joseph form by products with
  !> C and K alone: with A = P - K (C P), P+ = A - (A C') K' + K R K'
  !> (status /= 0: the innovation covariance is not positive definite).
  subroutine ekf_update(m, p, ifree, bias, r, delta, t, u, z, xa, pc, c, status)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), bias(:), r(:), delta, t, u(:), z(:)
    integer, intent(in) :: ifree(:)
    real(wp), intent(inout) :: xa(:), pc(:, :)
    real(wp), intent(out) :: c(:, :)            !< dy/dxa at the prediction
    integer, intent(out) :: status
    real(wp) :: y(m%ny), sy(m%ny, m%ny), si(m%ny, m%ny), cp(m%ny, size(xa)), &
                kg(size(xa), m%ny), logdet
    integer :: i
    if (delta > 0.0_wp) then
      call filter_outputs(m, p, ifree, bias, t, u, xa, y)
      call central_differences(m, p, ifree, t, u, xa, delta, .false., c)
    else
      call filter_outputs(m, p, ifree, bias, t, u, xa, y, c)
    end if
    cp = matmul(c, pc)                          ! C P = (P C')'
    sy = matmul(cp, transpose(c))
    do i = 1, m%ny
      sy(i, i) = sy(i, i) + r(i)
    end do
    call chol_inverse(sy, si, logdet, status)
    if (status /= 0) return
    kg = matmul(transpose(cp), si)              ! K = P C' S^-1
    xa = xa + matmul(kg, z - y)
    pc = pc - matmul(kg, cp)                    ! A = (I - K C) P
    pc = pc - matmul(matmul(pc, transpose(c)), transpose(kg)) + &
         matmul(kg*spread(r, 1, size(xa)), transpose(kg))
    pc = 0.5_wp*(pc + transpose(pc))
  end subroutine ekf_update

  !> diag(C P C'), the adaptive R's (mlid_online_filter's filter_adapt_r)
  !> with C at the prediction and P+.
  pure function cpc_diag(c, pc) result(d)
    real(wp), intent(in) :: c(:, :), pc(:, :)
    real(wp) :: d(size(c, 1)), cp(size(c, 1), size(c, 2))
    integer :: i
    cp = matmul(c, pc)
    do i = 1, size(c, 1)
      d(i) = dot_product(cp(i, :), c(i, :))
    end do
  end function cpc_diag

  !> The textbook's Jacobians for comparison: d f / d xa (state true; u
  !> with the noise inputs) or d y / d xa by central differences, each
  !> entry of xa moved by +-delta.
  subroutine central_differences(m, p, ifree, t, u, xa, delta, state, jac)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), t, u(:), xa(:), delta
    integer, intent(in) :: ifree(:)
    logical, intent(in) :: state
    real(wp), intent(out) :: jac(:, :)
    real(wp) :: xp(size(xa)), pp(size(p)), gp(size(jac, 1)), gm(size(jac, 1)), zb(size(jac, 1))
    integer :: j
    zb = 0.0_wp
    do j = 1, size(xa)
      xp = xa
      xp(j) = xa(j) + delta
      call at(xp, gp)
      xp(j) = xa(j) - delta
      call at(xp, gm)
      jac(:, j) = (gp - gm)/(2.0_wp*delta)
    end do
  contains
    subroutine at(xv, g)
      real(wp), intent(in) :: xv(:)
      real(wp), intent(out) :: g(:)
      if (state) then
        call filter_params(m, p, ifree, xv, pp)
        call m%f(t, xv(1:m%nx), u, pp, g)
      else
        call filter_outputs(m, p, ifree, zb, t, u, xv, g)
      end if
    end subroutine at
  end subroutine central_differences

end module mlid_online_ekf
