!> Equation-error start-up (report §4.4, §5.1.2): with every state
!> measured, the model parameters follow from one least-squares pass over
!>
!>   the state equations   xdot_m(t_j) = f(t_j, x_m(t_j), u_j, p)
!>   the output equations  y_i(t_j)    = h_i(t_j, x_m(t_j), u_j, p) + bias_i
!>
!> (measured states x_m in place of the states, their derivatives by
!> central differences; outputs that merely measure a state are left out).
!> Both are linear in p for the models here, so one Gauss-Newton step from
!> the start values solves them; the rows are weighted by the inverse
!> variance of each equation's residual, estimated in a first unweighted
!> pass.  The result starts the iterative methods.
module mlid_equation_error
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_SINGULAR
  use mlid_models, only: model_t, layout_t
  use mlid_params, only: param_map_t, apply_ties, input_delays, output_delays, stabilized
  use mlid_linalg, only: info_inverse
  implicit none
  private
  public :: equation_error

contains

  !> theta: the start values on entry, the equation-error estimates of the
  !> free model parameters and biases on exit; sigma: their least-squares
  !> standard deviations (free order).
  subroutine equation_error(m, theta, pm, t, u, y, theta_out, sigma, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    real(wp), intent(out) :: theta_out(:), sigma(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(layout_t) :: l
    integer :: nx, ny, nt, nf, i, k, pass, ndrop, bad, xout(m%nx)
    real(wp) :: c(m%ny, m%nx), dp(m%ny, size(pm%im)), b(m%nx, size(pm%im)), x(m%nx), xd(m%nx)
    real(wp) :: f(m%nx), h(m%ny), w(m%nx + m%ny), ss(m%nx + m%ny)
    real(wp) :: row(pm%nf), a(pm%nf, pm%nf), g(pm%nf), cov(pm%nf, pm%nf), ev(pm%nf), delta(pm%nf)
    logical :: eq_out(m%ny)
    real(wp), allocatable :: ua(:)

    l = pm%l
    nx = m%nx
    ny = m%ny
    nt = size(t)
    nf = pm%nf
    theta_out = theta
    sigma = 0.0_wp
    status = MLID_ERR_INPUT
    if (nf == 0) then
      status = MLID_OK
      msg = ''
      return
    end if
    if (size(pm%ix0) + size(pm%iq) + size(pm%ir) + size(pm%is) > 0) then
      msg = 'equation-error start-up estimates model parameters and biases only: fix x0 and '// &
            'the noise statistics'
      return
    end if
    if (output_delays(theta, pm) .or. input_delays(theta, pm) .or. stabilized(theta, l)) then
      msg = 'equation-error start-up takes the measured states as they are: no '// &
            'time delays or stabilizing gain (start without them)'
      return
    end if
    allocate (ua(m%nu + m%nw))
    ua = 0.0_wp
    ! Which output measures each state: dh_i/dx = e_k and no parameter in h_i.
    x = theta(l%ox0 + 1:l%ox0 + nx)
    ua(1:m%nu) = u(:, 1)
    call m%dhdx(t(1), x, u(:, 1), theta(1:l%np), c)
    call m%dhdp(t(1), x, u(:, 1), theta(1:l%np), pm%im, dp)
    xout = 0
    do i = 1, ny
      do k = 1, nx
        if (abs(c(i, k) - 1.0_wp) < 1.0e-12_wp .and. count(c(i, :) /= 0.0_wp) == 1 .and. &
            all(dp(i, :) == 0.0_wp) .and. xout(k) == 0) xout(k) = i
      end do
    end do
    if (any(xout == 0)) then
      write (msg, '(a,i0,a)') 'equation-error start-up needs every state measured: state ', &
        findloc(xout, 0, 1), ' is not an output'
      return
    end if
    eq_out = .true.
    eq_out(xout) = .false.

    ! Weights: the inverse residual variance of each equation, first at the
    ! start values, then at the first solution.
    delta = 0.0_wp
    w = 1.0_wp
    call sweep()
    do pass = 1, 2
      where (ss > 0.0_wp) w = (nt - 2)/ss
      call sweep()
      call info_inverse(a, 1.0e-12_wp, cov, ev, ndrop, bad, status, msg)
      if (status /= MLID_OK) return
      if (ndrop > 0) then
        status = MLID_ERR_SINGULAR
        write (msg, '(a,i0,a)') 'equation-error start-up: free parameter ', bad, &
          ' does not appear in any state or output equation with these data'
        return
      end if
      delta = delta + matmul(cov, g)
      if (pass == 1) call sweep()
    end do
    theta_out(pm%ifree) = theta(pm%ifree) + delta
    call apply_ties(pm%tie, theta_out)
    do k = 1, nf
      sigma(k) = sqrt(max(0.0_wp, cov(k, k)))
    end do
    status = MLID_OK
    msg = ''

  contains

    !> One pass over the record at theta + delta: normal equations a, g
    !> with weights w, and each equation's residual sum of squares ss.
    subroutine sweep()
      integer :: jj, kk, ii, iseg, ob
      a = 0.0_wp
      g = 0.0_wp
      ss = 0.0_wp
      iseg = 1
      do jj = 2, nt - 1
        ! central differences stay inside a manoeuvre (segment)
        if (iseg < l%nseg) then
          if (l%seg(iseg + 1) <= jj + 1) then
            if (l%seg(iseg + 1) == jj) iseg = iseg + 1
            cycle
          end if
        end if
        ob = l%obias + (iseg - 1)*ny
        x = y(xout, jj) - theta(ob + xout)
        xd = (y(xout, jj + 1) - y(xout, jj - 1))/(t(jj + 1) - t(jj - 1))
        ua(1:m%nu) = u(:, jj)
        call m%f(t(jj), x, ua, theta(1:l%np), f)
        call m%dfdp(t(jj), x, ua, theta(1:l%np), pm%im, b)
        do kk = 1, nx                     ! state equations
          row = 0.0_wp
          do ii = 1, size(pm%im)
            row(pm%cm(ii)) = row(pm%cm(ii)) + pm%wm(ii)*b(kk, ii)
          end do
          call add_row(xd(kk) - f(kk), kk)
        end do
        call m%h(t(jj), x, u(:, jj), theta(1:l%np), h)
        call m%dhdp(t(jj), x, u(:, jj), theta(1:l%np), pm%im, dp)
        do kk = 1, ny                     ! output equations
          if (.not. eq_out(kk)) cycle
          row = 0.0_wp
          do ii = 1, size(pm%im)
            row(pm%cm(ii)) = row(pm%cm(ii)) + pm%wm(ii)*dp(kk, ii)
          end do
          do ii = 1, size(pm%ib)
            if (pm%ib(ii) == (iseg - 1)*ny + kk) row(pm%cb(ii)) = row(pm%cb(ii)) + pm%wb(ii)
          end do
          call add_row(y(kk, jj) - h(kk) - theta(ob + kk), nx + kk)
        end do
      end do
    end subroutine sweep

    !> Equation k's residual at theta + delta (the equations are linear in
    !> the parameters) into the normal equations and its sum of squares.
    subroutine add_row(e0, k)
      real(wp), intent(in) :: e0
      integer, intent(in) :: k
      real(wp) :: e
      e = e0 - dot_product(row, delta)
      a = a + w(k)*spread(row, 1, nf)*spread(row, 2, nf)
      g = g + w(k)*e*row
      ss(k) = ss(k) + e*e
    end subroutine add_row

  end subroutine equation_error

end module mlid_equation_error
