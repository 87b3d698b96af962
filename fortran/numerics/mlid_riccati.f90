!> The steady-state covariance of the Kalman filter's one-step prediction,
!> and its partials.
!>
!> The prediction covariance P = P(j|j-1) of a time-invariant filter with
!> transition A, output matrix C, state noise Q (nx x nx), measurement noise
!> R and their cross-covariance G = E{w v'} (nx x ny, as it reaches the
!> state) tends to the solution of the discrete algebraic Riccati equation
!>
!>     P = A P A' + Q - (A P C' + G) (C P C' + R)^-1 (A P C' + G)'.
!>
!> dare_solve finds it by the structured doubling algorithm (Chu, Fan, Lin
!> and Wang, 2004): after the cross term is taken out (A - G R^-1 C and
!> Q - G R^-1 G'), each doubling step doubles the horizon of the Riccati
!> recursion, so some 30 steps stand for 10^9 of them, however slowly the
!> recursion itself would settle (small R, slow modes).  The solution's
!> residual is checked.
!>
!> A partial dP of P follows from the same equation differentiated: with the
!> predictor gain Kp = (A P C' + G) B^-1 and the closed loop Ac = A - Kp C,
!>
!>     dP = Ac dP Ac' + E,
!>     E = Y + Y' + dQ - dG Kp' - Kp dG' + Kp dR Kp',  Y = dA P Ac' - Ac P dC' Kp',
!>
!> a Stein (discrete Lyapunov) equation, solved for all partials with one
!> factorisation of I - Ac (x) Ac (stein_solve).
module mlid_riccati
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_SINGULAR, MLID_ERR_NOCONV
  use mlid_linalg, only: solve, chol_inverse
  use mlid_text, only: es_text
  implicit none
  private
  public :: dare_solve, stein_solve, riccati_residual

  integer, parameter :: MAX_DOUBLINGS = 100
  !> A solution whose residual exceeds this fraction of max(|P|, |Q|) is refused.
  real(wp), parameter :: RESIDUAL_TOL = 1.0e-6_wp

contains

  !> P solving the Riccati equation above; status MLID_ERR_NOCONV with a
  !> message when the doubling does not settle or the residual is too large
  !> (no stabilising solution: a mode neither damped nor observed), and
  !> MLID_ERR_SINGULAR when R is not positive definite.
  subroutine dare_solve(a, c, q, r, g, p, status, msg)
    real(wp), intent(in) :: a(:, :), c(:, :), q(:, :), r(:, :), g(:, :)
    real(wp), intent(out) :: p(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: rinv(size(r, 1), size(r, 1)), logdet, grinv(size(a, 1), size(r, 1))
    real(wp), dimension(size(a, 1), size(a, 1)) :: ak, gk, hk, w, x1, x2, hnew
    integer :: it, ierr, i, n
    real(wp) :: res

    n = size(a, 1)
    p = 0.0_wp
    call chol_inverse(r, rinv, logdet, ierr)
    if (ierr /= 0) then
      status = MLID_ERR_SINGULAR
      msg = 'steady-state Kalman filter: the measurement-noise covariance R is not positive definite'
      return
    end if
    ! the dual (control) form X = A~' X A~ - ... with A~ = (A - G R^-1 C)'
    grinv = matmul(g, rinv)
    ak = transpose(a - matmul(grinv, c))
    gk = matmul(transpose(c), matmul(rinv, c))
    hk = q - matmul(grinv, transpose(g))
    hk = 0.5_wp*(hk + transpose(hk))
    do it = 1, MAX_DOUBLINGS
      w = matmul(gk, hk)
      do i = 1, n
        w(i, i) = w(i, i) + 1.0_wp
      end do
      call solve(w, ak, x1, ierr)                     ! (I + G H)^-1 A
      if (ierr == 0) call solve(w, gk, x2, ierr)      ! (I + G H)^-1 G
      if (ierr /= 0) exit
      hnew = hk + matmul(transpose(ak), matmul(hk, x1))
      gk = gk + matmul(ak, matmul(x2, transpose(ak)))
      ak = matmul(ak, x1)
      hnew = 0.5_wp*(hnew + transpose(hnew))
      gk = 0.5_wp*(gk + transpose(gk))
      if (.not. all(ieee_is_finite(hnew))) exit
      if (maxval(abs(hnew - hk)) <= 1.0e-15_wp*maxval(abs(hnew))) then
        hk = hnew
        exit
      end if
      hk = hnew
    end do
    p = hk
    res = riccati_residual(a, c, q, r, g, p)
    if (ierr /= 0 .or. it > MAX_DOUBLINGS .or. .not. res <= RESIDUAL_TOL) then
      status = MLID_ERR_NOCONV
      msg = 'steady-state Kalman filter: no stabilising solution of the Riccati equation '// &
            '(relative residual '//es_text(res, 9, 2)//'): a mode is neither damped nor seen '// &
            'in the outputs, or R is too small'
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine dare_solve

  !> |P - (A P A' + Q - (A P C' + G) B^-1 (A P C' + G)')| relative to
  !> max(|P|, |Q|), largest entries; huge when B is not positive definite.
  real(wp) function riccati_residual(a, c, q, r, g, p) result(res)
    real(wp), intent(in) :: a(:, :), c(:, :), q(:, :), r(:, :), g(:, :), p(:, :)
    real(wp) :: b(size(r, 1), size(r, 1)), binv(size(r, 1), size(r, 1)), logdet
    real(wp) :: m(size(a, 1), size(r, 1)), e(size(a, 1), size(a, 1))
    integer :: ierr
    res = huge(1.0_wp)
    if (.not. all(ieee_is_finite(p))) return
    b = matmul(c, matmul(p, transpose(c))) + r
    call chol_inverse(0.5_wp*(b + transpose(b)), binv, logdet, ierr)
    if (ierr /= 0) return
    m = matmul(a, matmul(p, transpose(c))) + g
    e = p - matmul(a, matmul(p, transpose(a))) - q + matmul(m, matmul(binv, transpose(m)))
    res = maxval(abs(e))/max(maxval(abs(p)), maxval(abs(q)), tiny(1.0_wp))
  end function riccati_residual

  !> x(:, :, k) = ac x(:, :, k) ac' + e(:, :, k) for every k, by one LU
  !> factorisation of I - ac (x) ac (n^2 unknowns: the filters here have a
  !> handful of states).  info > 0: ac has eigenvalues whose products are 1
  !> (the closed loop is not stable).
  subroutine stein_solve(ac, e, x, info)
    real(wp), intent(in) :: ac(:, :), e(:, :, :)
    real(wp), intent(out) :: x(:, :, :)
    integer, intent(out) :: info
    real(wp) :: k(size(ac, 1)**2, size(ac, 1)**2), rhs(size(ac, 1)**2, size(e, 3))
    real(wp) :: sol(size(ac, 1)**2, size(e, 3))
    integer :: n, i, j, p, q

    n = size(ac, 1)
    info = 0
    if (size(e, 3) == 0) return
    ! vec(A X A') = (A (x) A) vec(X), column-major vec: row (i,j) -> i + (j-1) n
    do q = 1, n
      do p = 1, n
        do j = 1, n
          do i = 1, n
            k(i + (j - 1)*n, p + (q - 1)*n) = -ac(i, p)*ac(j, q)
          end do
        end do
      end do
    end do
    do i = 1, n*n
      k(i, i) = k(i, i) + 1.0_wp
    end do
    rhs = reshape(e, [n*n, size(e, 3)])
    call solve(k, rhs, sol, info)
    if (info /= 0) return
    x = reshape(sol, shape(x))
    do i = 1, size(x, 3)
      x(:, :, i) = 0.5_wp*(x(:, :, i) + transpose(x(:, :, i)))
    end do
  end subroutine stein_solve

end module mlid_riccati
