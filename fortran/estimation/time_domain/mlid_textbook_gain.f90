!> The steady-state gain of the textbook's filter error (Jategaonkar,
!> FVSysID ch. 5, ml_fem2; noise_criterion = 'textbook'), with its partials.
!>
!> The model is linearised once, at the first manoeuvre's initial state and
!> the first input sample, with mlid's exact Jacobians: A = df/dx, C = dh/dx,
!> Gamma = df/dw.  The process noise is continuous, density V = Gamma Q
!> Gamma' (Q = diag(q^2) for continuous_sd, the textbook's F F'; diag(q)
!> for continuous).  The measurement noise R = diag(r) enters as the
!> density R dt, with no C P C' in the inverse:
!>
!>     A P + P A' + V - P C' (R dt)^-1 C P = 0,   K = P C' R^-1   (eqs 5.15, 5.48)
!>
!> The partials follow from the same equation differentiated, a continuous
!> Lyapunov equation in the closed loop Ac = A - P C' (R dt)^-1 C:
!>
!>     Ac dP + dP Ac' + dA P + P dA' + dV - P dG P = 0,  dG = (dC' R^-1 C + C' R^-1 dC)/dt,
!>     dK = dP C' R^-1 + P dC' R^-1.
!>
!> dA/dp, dC/dp and dGamma/dp, which would need second derivatives of f and
!> h (the model kinds do not all give d(dh/dx)/dp), are central differences
!> of the analytic df/dp and dh/dp over the state and the noise (exact up to
!> rounding for a linear model, second-order for a nonlinear one); a free
!> initial state moves A and C through central differences of df/dx and
!> dh/dx.  R is not
!> a parameter here (the criterion sets it from the innovations).
module mlid_textbook_gain
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_DIVERGED
  use mlid_models, only: model_t
  use mlid_params, only: param_map_t
  use mlid_options, only: options_t
  use mlid_riccati, only: care_solve, lyap_solve
  use mlid_memory, only: no_memory
  implicit none
  private
  public :: textbook_t, textbook_gain

  !> Relative step of the central differences of the analytic Jacobians.
  real(wp), parameter :: DIFF_STEP = 1.0e-5_wp

  !> The gain and what the criterion needs of it (nf: free parameters).
  type :: textbook_t
    real(wp), allocatable :: k(:, :), dk(:, :, :)   !< K (nx, ny) and dK/dtheta (nx, ny, nf)
    real(wp), allocatable :: c(:, :)                !< C = dh/dx (ny, nx)
    real(wp), allocatable :: cg(:, :)               !< C Gamma (ny, nw): how the noise is seen
    real(wp), allocatable :: kc(:), dkc(:, :)       !< diag(K C) (nx) and its partials (nx, nf)
  end type textbook_t

contains

  !> The textbook gain at theta (map pm, record t, u; opt%process_noise says
  !> what q are); with partials, dK and d diag(KC) too.
  subroutine textbook_gain(m, theta, pm, t, u, opt, partials, tg, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), t(:), u(:, :)
    type(param_map_t), intent(in) :: pm
    type(options_t), intent(in) :: opt
    logical, intent(in) :: partials
    type(textbook_t), intent(out) :: tg
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: a(m%nx, m%nx), gam(m%nx, m%nw), q(m%nw, m%nw), v(m%nx, m%nx), p(m%nx, m%nx)
    real(wp) :: rinv(m%ny, m%ny), g(m%nx, m%nx), dt, x0(m%nx), ue(m%nu + m%nw)
    real(wp), allocatable :: da(:, :, :), dc(:, :, :), dv(:, :, :), dp(:, :, :), e(:, :, :)
    integer :: nx, ny, nf, i, c

    nx = m%nx
    ny = m%ny
    nf = pm%nf
    call check(status, msg)
    if (status /= MLID_OK) return
    dt = t(2) - t(1)
    x0 = theta(pm%l%ox0 + 1:pm%l%ox0 + nx)
    ue = 0.0_wp
    ue(1:m%nu) = u(:, 1)
    allocate (tg%k(nx, ny), tg%c(ny, nx), tg%cg(ny, m%nw), tg%kc(nx), stat=i)
    if (i /= 0) then
      call no_memory('the textbook gain', real(nx, wp)*(2*ny + 1) + ny*m%nw, status, msg)
      return
    end if
    call m%dfdx(t(1), x0, ue, theta(1:pm%l%np), a)
    call m%dfdw(t(1), x0, ue, theta(1:pm%l%np), gam)
    call m%dhdx(t(1), x0, u(:, 1), theta(1:pm%l%np), tg%c)
    q = 0.0_wp
    rinv = 0.0_wp
    do i = 1, m%nw
      q(i, i) = merge(theta(pm%l%oq + i)**2, theta(pm%l%oq + i), opt%process_noise == 2)
    end do
    do i = 1, ny
      rinv(i, i) = 1.0_wp/theta(pm%l%or + i)
    end do
    v = matmul(gam, matmul(q, transpose(gam)))
    g = matmul(transpose(tg%c), matmul(rinv, tg%c))/dt
    if (.not. (all(ieee_is_finite(a)) .and. all(ieee_is_finite(tg%c)) .and. &
               all(ieee_is_finite(gam)))) then
      status = MLID_ERR_DIVERGED
      msg = 'textbook filter gain: the linearisation at x0 and the first input is not finite'
      return
    end if
    call care_solve(a, g, v, p, status, msg)
    if (status /= MLID_OK) return
    tg%k = matmul(p, matmul(transpose(tg%c), rinv))
    tg%cg = matmul(tg%c, gam)
    do i = 1, nx
      tg%kc(i) = dot_product(tg%k(i, :), tg%c(:, i))
    end do
    if (.not. partials) return
    allocate (da(nx, nx, nf), dc(ny, nx, nf), dv(nx, nx, nf), dp(nx, nx, nf), e(nx, nx, nf), &
              tg%dk(nx, ny, nf), tg%dkc(nx, nf), stat=i)
    if (i /= 0) then
      call no_memory('the textbook gain''s partials', real(nx, wp)*nf*(4*nx + 2*ny + 1), &
                     status, msg)
      return
    end if
    call system_partials(m, theta, pm, t, u, ue, x0, q, gam, opt%process_noise == 2, da, dc, dv)
    do c = 1, nf
      e(:, :, c) = matmul(da(:, :, c), p)
      e(:, :, c) = e(:, :, c) + transpose(e(:, :, c)) + dv(:, :, c) - &
                   matmul(p, matmul(dgain_g(dc(:, :, c)), p))
    end do
    call lyap_solve(a - matmul(p, g), e, dp, i)
    if (i /= 0) then
      status = MLID_ERR_DIVERGED
      msg = 'textbook filter gain: its partials have no unique solution (closed loop not stable)'
      return
    end if
    do c = 1, nf
      tg%dk(:, :, c) = matmul(dp(:, :, c), matmul(transpose(tg%c), rinv)) + &
                       matmul(p, matmul(transpose(dc(:, :, c)), rinv))
      do i = 1, nx
        tg%dkc(i, c) = dot_product(tg%dk(i, :, c), tg%c(:, i)) + &
                       dot_product(tg%k(i, :), dc(:, i, c))
      end do
    end do

  contains

    !> dG = (dC' R^-1 C + C' R^-1 dC)/dt.
    function dgain_g(dcc) result(dg)
      real(wp), intent(in) :: dcc(:, :)
      real(wp) :: dg(nx, nx)
      dg = matmul(transpose(dcc), matmul(rinv, tg%c))
      dg = (dg + transpose(dg))/dt
    end function dgain_g

    subroutine check(status, msg)
      integer, intent(out) :: status
      character(len=*), intent(out) :: msg
      status = MLID_ERR_INPUT
      if (size(t) < 2) then
        msg = 'textbook filter gain: the record needs two samples at least'
      else if (.not. all(theta(pm%l%oq + 1:pm%l%oq + m%nw) >= 0.0_wp)) then
        msg = 'process noise q must be >= 0'
      else if (.not. all(theta(pm%l%or + 1:pm%l%or + ny) > 0.0_wp)) then
        msg = 'measurement-noise variances r must be > 0'
      else
        status = MLID_OK
        msg = ''
      end if
    end subroutine check

  end subroutine textbook_gain

  !> dA, dC and dV = d(Gamma Q Gamma') for each free column: the model
  !> parameters through central differences of the analytic df/dp and
  !> dh/dp; q through Q; a free initial state (first manoeuvre)
  !> through central differences of df/dx and dh/dx.
  subroutine system_partials(m, theta, pm, t, u, ue, x0, q, gam, sdev, da, dc, dv)
    class(model_t), intent(in) :: m
    logical, intent(in) :: sdev     !< q are standard deviations (continuous_sd)
    real(wp), intent(in) :: theta(:), t(:), u(:, :), ue(:), x0(:), q(:, :), gam(:, :)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(out) :: da(:, :, :), dc(:, :, :), dv(:, :, :)
    real(wp) :: bp(m%nx, size(pm%im)), bm(m%nx, size(pm%im))
    real(wp) :: dp_(m%ny, size(pm%im)), dm_(m%ny, size(pm%im))
    real(wp) :: dgam(m%nx, m%nw, size(pm%im)), xs(m%nx), us(size(ue)), h, y(m%nx, m%nx)
    real(wp) :: ap(m%nx, m%nx), am(m%nx, m%nx), cp(m%ny, m%nx), cm(m%ny, m%nx), dq(m%nw, m%nw)
    integer :: i, k, col, nx, np

    nx = m%nx
    np = pm%l%np
    da = 0.0_wp
    dc = 0.0_wp
    dv = 0.0_wp
    dgam = 0.0_wp
    if (size(pm%im) > 0) then
      do i = 1, nx + m%nw          ! d(df/dp)/dx_i and d(dh/dp)/dx_i, then d(df/dp)/dw_i
        xs = x0
        us = ue
        if (i <= nx) then
          h = DIFF_STEP*max(1.0_wp, abs(x0(i)))
          xs(i) = x0(i) + h
        else
          h = DIFF_STEP
          us(m%nu + i - nx) = h
        end if
        call m%dfdp(t(1), xs, us, theta(1:np), pm%im, bp)
        if (i <= nx) call m%dhdp(t(1), xs, u(:, 1), theta(1:np), pm%im, dp_)
        if (i <= nx) then
          xs(i) = x0(i) - h
        else
          us(m%nu + i - nx) = -h
        end if
        call m%dfdp(t(1), xs, us, theta(1:np), pm%im, bm)
        if (i <= nx) call m%dhdp(t(1), xs, u(:, 1), theta(1:np), pm%im, dm_)
        do k = 1, size(pm%im)
          col = pm%cm(k)
          if (i <= nx) then
            da(:, i, col) = da(:, i, col) + pm%wm(k)*(bp(:, k) - bm(:, k))/(2*h)
            dc(:, i, col) = dc(:, i, col) + pm%wm(k)*(dp_(:, k) - dm_(:, k))/(2*h)
          else
            dgam(:, i - nx, k) = (bp(:, k) - bm(:, k))/(2*h)
          end if
        end do
      end do
      do k = 1, size(pm%im)
        col = pm%cm(k)
        y = matmul(dgam(:, :, k), matmul(q, transpose(gam)))
        dv(:, :, col) = dv(:, :, col) + pm%wm(k)*(y + transpose(y))
      end do
    end if
    do k = 1, size(pm%iq)
      dq = 0.0_wp
      i = pm%iq(k)
      dq(i, i) = merge(2.0_wp*theta(pm%l%oq + i), 1.0_wp, sdev)
      dv(:, :, pm%cq(k)) = dv(:, :, pm%cq(k)) + pm%wq(k)*matmul(gam, matmul(dq, transpose(gam)))
    end do
    do k = 1, size(pm%ix0)
      i = pm%ix0(k)
      if (i > nx) cycle                ! another manoeuvre's: not the linearisation point
      h = DIFF_STEP*max(1.0_wp, abs(x0(i)))
      xs = x0
      xs(i) = x0(i) + h
      call m%dfdx(t(1), xs, ue, theta(1:np), ap)
      call m%dhdx(t(1), xs, u(:, 1), theta(1:np), cp)
      xs(i) = x0(i) - h
      call m%dfdx(t(1), xs, ue, theta(1:np), am)
      call m%dhdx(t(1), xs, u(:, 1), theta(1:np), cm)
      da(:, :, pm%cx0(k)) = da(:, :, pm%cx0(k)) + pm%wx0(k)*(ap - am)/(2*h)
      dc(:, :, pm%cx0(k)) = dc(:, :, pm%cx0(k)) + pm%wx0(k)*(cp - cm)/(2*h)
    end do

  end subroutine system_partials

end module mlid_textbook_gain
